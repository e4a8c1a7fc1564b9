"""GPU buffers: std430 structs written once for GLSL and NumPy, and a memory guard.

    Particle = Struct("Particle", [("position", "vec3"), ("mass", "float"),
                                   ("velocity", "vec3"), ("flags", "uint"),
                                   ("weights", "float", 4)])
    Particle.glsl()          # "struct Particle {\\n    vec3 position;\\n ..."
    Particle.block("Particles", "particles", binding=0)   # the SSBO declaration
    a = Particle.zeros(n)    # numpy structured array with the std430 offsets and stride
    buf = buffer(ctx, a, what="particles")                 # checked against GPU memory first

std430 rules (OpenGL 4.6 spec, 7.6.2.2): a scalar is aligned to 4; a vec2 to 8; a vec3
and a vec4 to 16 (a vec3 is 12 bytes, so a float may follow it in the same 16); a matrix
is an array of its column vectors; an array's stride is its element's size rounded up to
the element's alignment (so ``float[4]`` has stride 4, ``vec3[2]`` stride 16); a struct is
aligned to its largest member's alignment and its size rounded up to that.

NumPy shapes: a ``vecN`` field is ``(N,)``; a ``matCxR`` is ``(C, R_padded)`` indexed
``[column, row]`` (write ``M.T`` for a row-major NumPy matrix; ``mat3`` columns are padded
to 4); an array of ``vec3`` is ``(n, 4)`` with the 4th component padding.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GPUMemoryError, UsageError

# GLSL type -> (numpy base, components per column, columns). Matrices are column arrays.
_TYPES: dict[str, tuple[str, int, int]] = {
    "float": ("<f4", 1, 1), "int": ("<i4", 1, 1), "uint": ("<u4", 1, 1),
    "vec2": ("<f4", 2, 1), "vec3": ("<f4", 3, 1), "vec4": ("<f4", 4, 1),
    "ivec2": ("<i4", 2, 1), "ivec3": ("<i4", 3, 1), "ivec4": ("<i4", 4, 1),
    "uvec2": ("<u4", 2, 1), "uvec3": ("<u4", 3, 1), "uvec4": ("<u4", 4, 1),
    "mat2": ("<f4", 2, 2), "mat3": ("<f4", 3, 3), "mat4": ("<f4", 4, 4),
}


# GLSL keywords (and reserved words) that cannot name a struct or a field.
_GLSL_RESERVED = frozenset("""
attribute const uniform varying buffer shared coherent volatile restrict readonly writeonly atomic_uint
layout centroid flat smooth noperspective patch sample break continue do for while switch case default
if else subroutine in out inout float double int void bool true false invariant precise discard return
lowp mediump highp precision struct uint common partition active asm class union enum typedef template
this resource goto inline noinline public static extern external interface long short half fixed
unsigned superp input output filter sizeof cast namespace using sampler image texture
""".split()) | {f"{p}{t}{n}" for p in ("", "i", "u", "b", "d") for t in ("vec",) for n in (2, 3, 4)} \
    | {f"{d}mat{n}" for d in ("", "d") for n in (2, 3, 4)}


def _check_name(name, what: str) -> None:
    if not isinstance(name, str) or not name.isidentifier() or not name.isascii():
        raise UsageError(f"bad GLSL {what} name {name!r}")
    if name in _GLSL_RESERVED or name.startswith("gl_") or "__" in name:
        raise UsageError(f"{name!r} is reserved in GLSL and cannot be a {what} name")


def _vec_align(n: int) -> int:
    return {1: 4, 2: 8, 3: 16, 4: 16}[n]


def _round_up(x: int, a: int) -> int:
    return (x + a - 1) // a * a


@dataclass(frozen=True)
class Field:
    name: str
    type: "str | Struct"
    count: int | None      # None: not an array
    offset: int
    align: int
    size: int              # bytes the field spans (arrays: count * stride)
    stride: int | None     # array stride, else None

    @property
    def glsl_type(self) -> str:
        return self.type.name if isinstance(self.type, Struct) else self.type


class Struct:
    """A std430 struct: one definition gives the NumPy dtype and the GLSL declaration.

    ``fields`` are ``(name, type)`` or ``(name, type, count)``; a type is a GLSL type name
    (float int uint vec2-4 ivec2-4 uvec2-4 mat2-4) or another ``Struct``.
    """

    def __init__(self, name: str, fields):
        _check_name(name, "struct")
        self.name = name
        laid: list[Field] = []
        offset = 0
        align = 4
        seen = set()
        for spec in fields:
            if len(spec) not in (2, 3):
                raise UsageError(f"struct {name}: a field is (name, type) or (name, type, count), not {spec!r}")
            fname, ftype = spec[0], spec[1]
            count = spec[2] if len(spec) == 3 else None
            _check_name(fname, f"{name} field")
            if fname in seen:
                raise UsageError(f"struct {name}: repeated field name {fname!r}")
            seen.add(fname)
            if count is not None and (not isinstance(count, int) or count < 1):
                raise UsageError(f"struct {name}.{fname}: array count must be a positive int, not {count!r}")
            falign, fsize = _align_size(ftype, f"{name}.{fname}")
            if count is None:
                stride, span = None, fsize
            else:
                stride = _round_up(fsize, falign)
                span = stride * count
            offset = _round_up(offset, falign)
            laid.append(Field(fname, ftype, count, offset, falign, span, stride))
            offset += span
            align = max(align, falign)
        if not laid:
            raise UsageError(f"struct {name} has no fields")
        self.fields: tuple[Field, ...] = tuple(laid)
        self.alignment = align
        self.size = _round_up(offset, align)
        self.dtype = np.dtype({
            "names": [f.name for f in laid],
            "formats": [_numpy_format(f) for f in laid],
            "offsets": [f.offset for f in laid],
            "itemsize": self.size,
        })

    # ------------------------------------------------------------------ NumPy side
    @property
    def offsets(self) -> dict[str, int]:
        return {f.name: f.offset for f in self.fields}

    def zeros(self, n: int) -> np.ndarray:
        return np.zeros(int(n), dtype=self.dtype)

    # ------------------------------------------------------------------ GLSL side
    def glsl(self, *, nested: bool = True) -> str:
        """The ``struct`` declaration, preceded by those of nested structs (each once)."""
        out: list[str] = []
        if nested:
            for dep in self._dependencies():
                out.append(dep.glsl(nested=False))
        lines = [f"struct {self.name} {{"]
        for f in self.fields:
            arr = f"[{f.count}]" if f.count is not None else ""
            lines.append(f"    {f.glsl_type} {f.name}{arr};  // offset {f.offset}")
        lines.append(f"}};  // std430: {self.size} bytes, aligned to {self.alignment}")
        out.append("\n".join(lines))
        return "\n".join(out) + "\n"

    def block(self, block_name: str, instance: str, binding: int, *, qualifier: str = "",
              declare_struct: bool = False) -> str:
        """An SSBO of an unsized array of this struct:
        ``layout(std430, binding = 0) buffer Particles { Particle particles[]; };``"""
        q = f"{qualifier} " if qualifier else ""
        text = (f"layout(std430, binding = {int(binding)}) {q}buffer {block_name} "
                f"{{ {self.name} {instance}[]; }};\n")
        return (self.glsl() + text) if declare_struct else text

    def _dependencies(self) -> list["Struct"]:
        order: list[Struct] = []

        def visit(s: Struct):
            for f in s.fields:
                if isinstance(f.type, Struct) and f.type not in order:
                    visit(f.type)
                    if f.type not in order:
                        order.append(f.type)
        visit(self)
        return order

    def __repr__(self) -> str:
        return f"Struct({self.name!r}, size={self.size}, align={self.alignment})"


def _align_size(t, where: str) -> tuple[int, int]:
    if isinstance(t, Struct):
        return t.alignment, t.size
    if t not in _TYPES:
        raise UsageError(f"{where}: unsupported GLSL type {t!r}; use one of {', '.join(_TYPES)} or a Struct")
    _, n, cols = _TYPES[t]
    if cols == 1:
        return _vec_align(n), 4 * n
    col_align = _vec_align(n)  # a matrix is an array of columns: stride = aligned column
    return col_align, cols * _round_up(4 * n, col_align)


def _numpy_format(f: Field):
    if isinstance(f.type, Struct):
        base = f.type.dtype
        return base if f.count is None else (base, (f.count,))
    kind, n, cols = _TYPES[f.type]
    if cols > 1:
        padded = _round_up(4 * n, _vec_align(n)) // 4
        shape = (cols, padded)
    else:
        shape = (n,) if n > 1 else ()
    if f.count is not None:
        if cols == 1 and n > 1:
            shape = (f.count, f.stride // 4)  # vec3 arrays carry their padding
        else:
            shape = (f.count,) + shape
    return (kind, shape) if shape else kind


def std430_array_stride(glsl_type: str) -> int:
    """The stride of ``glsl_type x[]`` in a std430 block (float: 4, vec3: 16, mat3: 48)."""
    align, size = _align_size(glsl_type, "array")
    return _round_up(size, align)


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


def buffer(ctx, data_or_size, what: str = "buffer", *, dynamic: bool = False, ssbo: bool = True):
    """A moderngl Buffer from an array / bytes, or of ``size`` zeroed bytes, after ``check_allocation``.

    A GL_OUT_OF_MEMORY from the driver becomes GPUMemoryError.
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
    return buf


def _gl_error(ctx) -> str:
    try:
        return str(ctx.error)
    except Exception:
        return "GL_NO_ERROR"
