"""A GPU fence (glFenceSync / glClientWaitSync), which moderngl 5 does not expose: the CPU can
wait for the commands issued before it without waiting for those issued after.

    f = Fence()      # after the commands to wait for; flushes them to the GPU (glFlush)
    ...              # issue more work
    f.wait()         # blocks until the GPU has passed the fence; returns the seconds waited
    f.done()         # or asks without waiting: True once it has

Where the GL loader lacks the entry points, ``Fence()`` only flushes if it can and ``wait``
returns at once (a later read of a buffer then waits in the driver, as without a fence).
Call it on the thread whose context issued the commands.
"""
from __future__ import annotations

import ctypes
import time

from . import replay
from .entry_points import gl_entry

GL_SYNC_GPU_COMMANDS_COMPLETE = 0x9117
GL_SYNC_FLUSH_COMMANDS_BIT = 0x1
GL_TIMEOUT_EXPIRED = 0x911B
_fns: dict | None = None


def _gl() -> dict:
    global _fns
    if _fns is None:
        _fns = {"fence": gl_entry("glFenceSync", ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint),
                "wait": gl_entry("glClientWaitSync", ctypes.c_uint, ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint64),
                "delete": gl_entry("glDeleteSync", None, ctypes.c_void_p),
                "flush": gl_entry("glFlush", None)}
    return _fns


def available() -> bool:
    f = _gl()
    return all(f[k] is not None for k in ("fence", "wait", "delete"))


class Fence:
    def __init__(self):
        replay.side("a fence")   # the frame reads it later (gpu/replay.py)
        f = _gl()
        self._sync = f["fence"](GL_SYNC_GPU_COMMANDS_COMPLETE, 0) if available() else None
        if f["flush"] is not None:
            f["flush"]()   # the GPU starts on what is queued now, not at the next implicit flush

    def wait(self) -> float:
        if self._sync is None:
            return 0.0
        f = _gl()
        t = time.perf_counter()
        try:
            for _ in range(120):   # 1 s a try; after 2 minutes a read of the buffers waits instead
                if f["wait"](self._sync, GL_SYNC_FLUSH_COMMANDS_BIT, 1_000_000_000) != GL_TIMEOUT_EXPIRED:
                    break          # signalled (or GL_WAIT_FAILED: the driver's read waits instead)
        finally:
            self.release()
        return time.perf_counter() - t

    def done(self) -> bool:
        """Whether the GPU has passed the fence, without waiting (True without fences: a read
        then waits in the driver, as without one)."""
        if self._sync is None:
            return True
        replay.side("a fence read")
        if _gl()["wait"](self._sync, 0, 0) == GL_TIMEOUT_EXPIRED:
            return False
        self.release()
        return True

    def release(self) -> None:
        if self._sync is not None:
            _gl()["delete"](self._sync)
            self._sync = None
