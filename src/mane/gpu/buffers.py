"""GPU buffers and the memory guard: every large allocation is checked against
``memory_budget`` (driver memory info, ``MANE_GPU_MEMORY``, half the RAM on llvmpipe) before
anything is allocated.

    check_allocation(ctx, nbytes, "the expanded strands")     # GPUMemoryError if it does not fit
    buf = buffer(ctx, array, what="particles")                 # checked, then allocated

and the read-back of buffers the GPU works on: ``DeviceBuffer.read`` (what ``buffer`` returns,
``as_device`` makes of any moderngl Buffer) goes through a GPU copy into a staging buffer, so
that the driver keeps the buffer itself in video memory (``read_buffer``).
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import moderngl
import numpy as np

from ..errors import GPUMemoryError, UsageError

# --------------------------------------------------------------------------- memory guard

def _fmt_bytes(n: int | float) -> str:
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TiB"  # pragma: no cover


ENV_BUDGET = "MANE_GPU_MEMORY"
"""Environment variable: the GPU memory mane may use, bytes with an optional K/M/G/T suffix
(binary: ``8G`` = 8 GiB). It lowers the budget the driver reports, or sets one where the
driver says nothing."""
SOFTWARE_RAM_FRACTION = 0.5
"""On a software renderer (llvmpipe) "GPU memory" is the machine's RAM: the budget is the RAM
available now, but at most this fraction of the total."""


@dataclass(frozen=True)
class Budget:
    """The GPU memory one allocation may take now, bytes (None: unknown), and who said so."""

    available: int | None
    total: int | None
    source: str


def _parse_bytes(text: str) -> int:
    t = str(text).strip().upper().removesuffix("B").removesuffix("I")
    scale = 1
    if t and t[-1] in "KMGT":
        scale = 1024 ** ("KMGT".index(t[-1]) + 1)
        t = t[:-1]
    try:
        v = float(t) * scale
    except ValueError:
        raise UsageError(f"{ENV_BUDGET}={text!r}: expected bytes like 8G, 512M or 1000000") from None
    if not v > 0 or v != v or v == float("inf"):
        raise UsageError(f"{ENV_BUDGET}={text!r}: must be a positive size")
    return int(v)


def memory_budget(ctx) -> Budget:
    """The GPU memory budget now: the driver's free video memory (GL_NVX_gpu_memory_info's
    GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX, or GL_ATI_meminfo's VBO_FREE_MEMORY_ATI),
    lowered by ``MANE_GPU_MEMORY`` when set (which alone gives the budget where the driver says
    nothing); on a software renderer the available RAM, at most half the machine's."""
    import os

    from .capabilities import get_capabilities, gpu_memory

    caps = get_capabilities(ctx)
    mem = gpu_memory(ctx, caps.extensions, caps.is_software)
    avail, total, source = mem.available, mem.total, mem.source
    if caps.is_software and total is not None:
        cap = int(total * SOFTWARE_RAM_FRACTION)
        avail = cap if avail is None else min(avail, cap)
        source += f", at most {SOFTWARE_RAM_FRACTION:g} of {_fmt_bytes(total)}"
    setting = os.environ.get(ENV_BUDGET)
    if setting:
        limit = _parse_bytes(setting)
        if avail is None or limit < avail:
            avail, source = limit, f"{ENV_BUDGET}={setting}"
    return Budget(avail, total, source)


def check_allocation(ctx, nbytes: int, what: str, *, ssbo: bool = True, reduce: str | None = None) -> None:
    """Raise GPUMemoryError before allocating ``nbytes`` for ``what`` when it cannot fit.

    Checks the budget of ``memory_budget`` (the driver's free memory on NVIDIA and AMD, system
    RAM for llvmpipe, ``MANE_GPU_MEMORY``) and, for buffers bound as shader storage
    (``ssbo=True``), the largest SSBO (GL_MAX_SHADER_STORAGE_BLOCK_SIZE: 128 MiB on llvmpipe,
    2 GiB or more on NVIDIA). ``reduce`` says what the user should make smaller.
    """
    from .capabilities import get_capabilities

    try:
        nbytes = int(nbytes)
    except (TypeError, ValueError, OverflowError):
        raise UsageError(f"{what}: buffer size must be an integer number of bytes, not {nbytes!r}") from None
    if nbytes < 0:
        raise UsageError(f"{what}: negative buffer size {nbytes}")
    advice = reduce or "Use fewer strands or points per strand"
    caps = get_capabilities(ctx)
    if ssbo:
        limit = caps.limits.get("max_shader_storage_block_size")
        if limit and nbytes > limit:
            raise GPUMemoryError(
                f"{what} needs {_fmt_bytes(nbytes)} ({nbytes} bytes) in one shader storage buffer, but "
                f"{caps.renderer} allows at most {_fmt_bytes(limit)} (GL_MAX_SHADER_STORAGE_BLOCK_SIZE). "
                f"{advice}, or a GPU with larger storage blocks.")
    budget = memory_budget(ctx)
    if budget.available is not None and nbytes > budget.available:
        raise GPUMemoryError(
            f"{what} needs {_fmt_bytes(nbytes)} but only {_fmt_bytes(budget.available)} of "
            f"{'GPU memory' if not caps.is_software else 'memory'} is free ({budget.source}"
            f"{', total ' + _fmt_bytes(budget.total) if budget.total else ''}). "
            f"{advice}, or free GPU memory (other programs, earlier scenes).")


def check_texture(ctx, size, components: int, itemsize: int, what: str, *, samples: int = 1,
                  reduce: str | None = None, extra_bytes: int = 0) -> int:
    """Check a texture or render target of ``size`` (w, h) or (w, h, d) texels before making it:
    its sides against GL_MAX_TEXTURE_SIZE (GL_MAX_3D_TEXTURE_SIZE), its bytes (times
    ``samples``, plus ``extra_bytes`` of companions allocated with it) against the budget.
    Returns the bytes."""
    from .capabilities import get_capabilities

    dims = [int(v) for v in size]
    caps = get_capabilities(ctx)
    key = "max_3d_texture_size" if len(dims) == 3 else "max_texture_size"
    side = caps.limits.get(key)
    advice = reduce or "Use a smaller size"
    if side and max(dims) > side:
        raise GPUMemoryError(f"{what} of {'x'.join(map(str, dims))} texels is larger than the "
                             f"{side} per side this GPU allows ({key.upper()}). {advice}.")
    nbytes = int(np.prod(dims, dtype=object)) * int(components) * int(itemsize) * max(1, int(samples))
    check_allocation(ctx, nbytes + int(extra_bytes), what, ssbo=False, reduce=reduce)
    return nbytes


def buffer(ctx, data_or_size, what: str = "buffer", *, dynamic: bool = False, ssbo: bool = True,
           host_read: bool = False):
    """A DeviceBuffer from an array / bytes, or of ``size`` zeroed bytes, after ``check_allocation``.

    ``host_read``: a plain moderngl Buffer instead, for the few words the CPU reads every frame a
    frame or more after the GPU wrote them (counters in a ring): its mapped read does not wait
    for the frames issued since, as a DeviceBuffer's GPU copy would; the driver may keep it in
    host memory, which suits a few words. A GL_OUT_OF_MEMORY from the driver becomes GPUMemoryError.
    """
    if isinstance(data_or_size, (int, np.integer)):
        nbytes, data = int(data_or_size), None
    else:
        if isinstance(data_or_size, np.ndarray):
            data = np.ascontiguousarray(data_or_size)
        else:
            data = memoryview(data_or_size)
        nbytes = data.nbytes
    if nbytes == 0:
        raise UsageError(f"{what}: cannot make an empty GPU buffer")
    check_allocation(ctx, nbytes, what, ssbo=ssbo)
    try:
        if data is None:
            buf = ctx.buffer(reserve=nbytes, dynamic=dynamic)
        else:
            buf = ctx.buffer(data, dynamic=dynamic)
    except MemoryError:
        raise GPUMemoryError(f"{what}: out of memory allocating {_fmt_bytes(nbytes)}") from None
    except Exception as exc:
        if "memory" in str(exc).lower():
            raise GPUMemoryError(f"{what}: the driver could not allocate {_fmt_bytes(nbytes)}: {exc}") from None
        raise
    err = _gl_error(ctx)
    if err == "GL_OUT_OF_MEMORY":
        try:
            buf.release()
        except Exception:
            pass
        raise GPUMemoryError(f"{what}: the driver ran out of memory allocating {_fmt_bytes(nbytes)} "
                             f"(GL_OUT_OF_MEMORY). Use a smaller groom or free GPU memory.")
    return buf if host_read else as_device(buf)


def _gl_error(ctx) -> str:
    try:
        return str(ctx.error)
    except Exception:
        return "GL_NO_ERROR"


# --------------------------------------------------------------------------- read-back
STAGING_BYTES = 64 << 20
"""The largest piece ``read_buffer`` copies into its staging buffer, and ``DeviceBuffer.clear``
writes, at once (bytes)."""

_staging: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # context -> its staging buffer


def _staging_buffer(ctx, nbytes: int):
    buf = _staging.get(ctx)
    if buf is None or buf.size < nbytes:
        if buf is not None:
            buf.release()
        size = 1 << max(12, (int(nbytes) - 1).bit_length())   # powers of two from 4 KiB: few regrowths
        buf = _staging[ctx] = ctx.buffer(reserve=size)
    return buf


def read_buffer_into(buf, out, size: int = -1, offset: int = 0, write_offset: int = 0) -> None:
    """Read ``size`` bytes of ``buf`` from ``offset`` (all of it after ``offset`` when negative)
    into the writable buffer ``out`` at ``write_offset``, through a GPU copy.

    NVIDIA's driver moves a buffer the CPU has read back to host memory ("DMA CACHED": its
    GL debug output says so, with "usage indicates that CPU is consuming buffer object data")
    and leaves it there, after which every shader that reads or writes the buffer goes over the
    bus: the simulate + render loop's renderer read the simulator's positions 6-17x slower after
    one ``read()`` of them. A GPU copy into a staging buffer of at most ``STAGING_BYTES``, read
    in pieces, leaves the buffer where it is; the staging buffer (one per context, kept) is the
    one that moves.
    """
    total = buf.size
    offset, size = int(offset), int(size)
    if size < 0:
        size = total - offset
    if offset < 0 or size < 0 or offset + size > total:
        raise UsageError(f"cannot read {size} bytes at offset {offset} of a {total}-byte buffer")
    if size == 0:
        return
    ctx = buf.ctx
    step = min(size, STAGING_BYTES)
    staging = _staging_buffer(ctx, step)
    for start in range(0, size, step):
        n = min(step, size - start)
        ctx.copy_buffer(staging, buf, size=n, read_offset=offset + start, write_offset=0)
        moderngl.Buffer.read_into(staging, out, size=n, offset=0, write_offset=int(write_offset) + start)


def read_buffer(buf, size: int = -1, offset: int = 0) -> bytearray:
    """``buf.read(size, offset)`` through a GPU copy (``read_buffer_into``), as the bytearray it
    was read into (bytes-like: not copied once more, which for a groom's positions is hundreds
    of MB)."""
    total = buf.size
    n = total - int(offset) if int(size) < 0 else int(size)
    out = bytearray(max(n, 0))
    read_buffer_into(buf, out, size, offset)
    return out


class DeviceBuffer(moderngl.Buffer):
    """A moderngl Buffer the GPU reads and writes and the CPU only reads back now and then: its
    ``read`` and ``read_into`` go through a GPU copy (``read_buffer_into``), so it stays in
    video memory. Bind and write it as any Buffer."""

    def read(self, size: int = -1, offset: int = 0) -> bytearray:
        return read_buffer(self, size, offset)

    def read_into(self, buffer, size: int = -1, offset: int = 0, write_offset: int = 0) -> None:
        read_buffer_into(self, buffer, size, offset, write_offset)

    def clear(self, size: int = -1, offset: int = 0, chunk=None) -> None:
        """Fill with zeros (or ``chunk`` repeated) by ``write``: moderngl's clear maps the buffer
        for the CPU to write, which moves it to host memory like a read."""
        offset, size = int(offset), int(size)
        if size < 0:
            size = self.size - offset
        if offset < 0 or size < 0 or offset + size > self.size:
            raise UsageError(f"cannot clear {size} bytes at offset {offset} of a {self.size}-byte buffer")
        pattern = b"\0" if chunk is None else bytes(chunk)
        if not pattern or size % len(pattern):
            raise UsageError(f"a clear pattern of {len(pattern)} bytes does not divide {size} bytes")
        piece = max(len(pattern), (min(size, STAGING_BYTES) // len(pattern)) * len(pattern))
        block = pattern * (piece // len(pattern))
        for start in range(0, size, piece):
            n = min(piece, size - start)
            self.write(block[:n] if n < piece else block, offset=offset + start)


def as_device(buf):
    """``buf`` (a moderngl Buffer) as a DeviceBuffer: its reads from now on through a GPU copy."""
    if not isinstance(buf, DeviceBuffer):
        buf.__class__ = DeviceBuffer
    return buf
