"""The driver's own messages (OpenGL 4.3 debug output): errors, performance warnings, and on
NVIDIA where it keeps each buffer, which is how the simulate + render loop's slow guide reads
were found (docs/performance.md, "Where the driver keeps a buffer").

    with DriverLog(ctx) as log:      # debug output on (synchronous), every message recorded
        ...                          # render, simulate
    log.summary()   # {"available", "messages", "kinds": [...], "buffer_moves": [...], "errors"}

``mane bench TARGET --driver-log`` runs a benchmark inside one and adds the summary to its JSON.
Synchronous debug output slows the driver, so timings taken inside a log are not comparable with
a run without one. Where the entry points are missing, ``available`` is False with a reason and
nothing is recorded. Call it on the thread whose context is current.
"""
from __future__ import annotations

import ctypes
import re

from .entry_points import gl_entry

GL_DEBUG_OUTPUT = 0x92E0
GL_DEBUG_OUTPUT_SYNCHRONOUS = 0x8242
GL_DONT_CARE = 0x1100
SOURCES = {0x8246: "api", 0x8247: "window_system", 0x8248: "shader_compiler", 0x8249: "third_party",
           0x824A: "application", 0x824B: "other"}
TYPES = {0x824C: "error", 0x824D: "deprecated", 0x824E: "undefined_behavior", 0x824F: "portability",
         0x8250: "performance", 0x8251: "other", 0x8268: "marker", 0x8269: "push_group", 0x826A: "pop_group"}
SEVERITIES = {0x9146: "high", 0x9147: "medium", 0x9148: "low", 0x826B: "notification"}
MAX_KINDS = 512          # distinct messages kept (the rest only counted)
TEXT_CHARS = 400         # of each kind's first message

DEBUGPROC = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_int,
                             ctypes.c_char_p, ctypes.c_void_p)
# NVIDIA: "Buffer object 1 (...) is being copied/moved from VIDEO memory to DMA CACHED memory."
_MOVE = re.compile(r"(?:copied|moved) from (\w[\w ]*?) memory to (\w[\w ]*?) memory", re.IGNORECASE)
_DIGITS = re.compile(r"\d+")


def _entries() -> dict:
    return {"enable": gl_entry("glEnable", None, ctypes.c_uint),
            "disable": gl_entry("glDisable", None, ctypes.c_uint),
            "is_enabled": gl_entry("glIsEnabled", ctypes.c_ubyte, ctypes.c_uint),
            "callback": gl_entry("glDebugMessageCallback", None, DEBUGPROC, ctypes.c_void_p),
            "control": gl_entry("glDebugMessageControl", None, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint,
                                ctypes.c_int, ctypes.c_void_p, ctypes.c_ubyte)}


class DriverLog:
    """Records the current context's debug messages between ``start`` and ``stop`` (or a ``with``
    block), grouped by kind: source, type, id, severity and the text with its numbers blanked."""

    def __init__(self, ctx=None):
        self.ctx = ctx
        self.kinds: dict[tuple, dict] = {}
        self.total = 0
        self.dropped = 0   # messages of kinds past MAX_KINDS
        self.reason = None
        self._fns = _entries()
        missing = [k for k, f in self._fns.items() if f is None]
        if missing:
            self.reason = "no OpenGL debug output here (" + ", ".join(missing) + " missing)"
        self._proc = None
        self._was = None

    @property
    def available(self) -> bool:
        return self.reason is None

    # ------------------------------------------------------------------ recording
    def record(self, source: int, kind: int, ident: int, severity: int, text: str) -> None:
        """One message (the callback's arguments; also for tests)."""
        self.total += 1
        key = (int(source), int(kind), int(ident), int(severity), _DIGITS.sub("#", text)[:TEXT_CHARS])
        entry = self.kinds.get(key)
        if entry is None:
            if len(self.kinds) >= MAX_KINDS:
                self.dropped += 1
                return
            entry = self.kinds[key] = {"source": SOURCES.get(source, hex(source)), "type": TYPES.get(kind, hex(kind)),
                                       "id": int(ident), "severity": SEVERITIES.get(severity, hex(severity)),
                                       "count": 0, "text": text[:TEXT_CHARS]}
        entry["count"] += 1

    def _callback(self, source, kind, ident, severity, length, message, user) -> None:
        try:   # an exception must not cross into the driver
            self.record(source, kind, ident, severity, (message or b"").decode("utf-8", "replace"))
        except Exception:
            pass

    def start(self) -> "DriverLog":
        if not self.available or self._proc is not None:
            return self
        f = self._fns
        self._was = tuple(bool(f["is_enabled"](cap)) for cap in (GL_DEBUG_OUTPUT, GL_DEBUG_OUTPUT_SYNCHRONOUS))
        self._proc = DEBUGPROC(self._callback)   # kept: the driver holds only its address
        f["enable"](GL_DEBUG_OUTPUT)
        f["enable"](GL_DEBUG_OUTPUT_SYNCHRONOUS)   # messages on this thread, while the call runs
        f["callback"](self._proc, None)
        f["control"](GL_DONT_CARE, GL_DONT_CARE, GL_DONT_CARE, 0, None, 1)
        return self

    def stop(self) -> None:
        if self._proc is None:
            return
        f = self._fns
        f["callback"](DEBUGPROC(), None)   # a null callback: the driver keeps messages to itself
        for cap, was in zip((GL_DEBUG_OUTPUT, GL_DEBUG_OUTPUT_SYNCHRONOUS), self._was):
            if not was:
                f["disable"](cap)
        self._proc = None

    def __enter__(self) -> "DriverLog":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # ------------------------------------------------------------------ report
    def buffer_moves(self) -> list[dict]:
        """The kinds that say a buffer was moved between memories (NVIDIA): from, to, count, text."""
        out = []
        for e in self.kinds.values():
            m = _MOVE.search(e["text"])
            if m:
                out.append({"from": m.group(1).strip().upper(), "to": m.group(2).strip().upper(),
                            "count": e["count"], "text": e["text"]})
        return out

    def summary(self) -> dict:
        kinds = sorted(self.kinds.values(), key=lambda e: -e["count"])
        return {"available": self.available, "reason": self.reason, "messages": self.total,
                "dropped": self.dropped, "errors": sum(e["count"] for e in kinds if e["type"] == "error"),
                "buffer_moves": self.buffer_moves(), "kinds": kinds,
                "note": "GL debug output (synchronous) was on: timings taken with it are not comparable"}

    def text(self, top: int = 8) -> str:
        """A few lines for a terminal."""
        s = self.summary()
        if not s["available"]:
            return f"driver messages: {s['reason']}"
        lines = [f"driver messages: {s['messages']} ({len(s['kinds'])} kinds, {s['errors']} errors, "
                 f"{sum(m['count'] for m in s['buffer_moves'])} buffer moves)"]
        lines += [f"  {e['count']:>6}  {e['type']:<11} {e['severity']:<12} {e['text'][:110]}" for e in s["kinds"][:top]]
        return "\n".join(lines)
