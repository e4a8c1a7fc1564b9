"""What this OpenGL context can do: renderer, limits, extensions, memory and mane's features.

    caps = Capabilities.query(ctx)
    caps.limits["max_tess_gen_level"]       # 64 on llvmpipe and NVIDIA
    caps.features["fragment_interlock"]     # Feature(available=False, reason="...")
    caps.require("compute_simulation")      # raises GLFeatureError saying what to do

moderngl's ``ctx.info`` has most ``GL_MAX_*`` values; the few it lacks (tessellation
levels, patch vertices, compute shared memory, GPU memory) are read with
``glGetIntegerv`` through ctypes, with the function pointers from glcontext's loader or
``eglGetProcAddress``. Anything that cannot be read is ``None``, never an exception.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import weakref
from dataclasses import dataclass, field

from ..errors import GLFeatureError
from .context import EGL_LIBRARIES, is_software_renderer, renderer_name

# --------------------------------------------------------------------------- GL functions

_GL_NO_ERROR = 0
_procs: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_egl_get_proc = None


def egl_library_names():
    """libEGL's names to load, in order: ``libEGL.so.1``, then what ``ctypes.util.find_library``
    finds, asked only when the first fails to load (it runs ``ldconfig -p``, and where that
    misses, a C compiler and the linker: a subprocess or three in a cold start)."""
    yield EGL_LIBRARIES["libegl"]
    yield ctypes.util.find_library("EGL")


def _egl_proc_address():
    """``eglGetProcAddress`` from libEGL.so.1, or None."""
    global _egl_get_proc
    if _egl_get_proc is None:
        fn = False
        for name in egl_library_names():
            if not name:
                continue
            try:
                lib = ctypes.CDLL(name)
                fn = lib.eglGetProcAddress
                fn.restype = ctypes.c_void_p
                fn.argtypes = [ctypes.c_char_p]
                break
            except (OSError, AttributeError):
                continue
        _egl_get_proc = fn
    return _egl_get_proc or None


def _load_address(ctx, name: str) -> int:
    # glcontext (moderngl's loader) knows the right library for EGL, GLX, WGL and windows.
    try:
        addr = ctx.mglo._context.load(name)
        if addr:
            return int(addr)
    except Exception:
        pass
    egl = _egl_proc_address()
    if egl is not None:
        try:
            return int(egl(name.encode()) or 0)
        except Exception:
            return 0
    return 0


def gl_function(ctx, name: str, restype, *argtypes):
    """A ctypes function for the GL entry point ``name`` of ``ctx``, or None when it has none.

    Call it only while ``ctx`` is current (``with ctx:`` makes a headless one current).
    """
    try:
        table = _procs.setdefault(ctx, {})
    except TypeError:  # not weak-referenceable: no caching
        table = {}
    key = (name, restype, argtypes)
    if key not in table:
        addr = _load_address(ctx, name)
        table[key] = ctypes.CFUNCTYPE(restype, *argtypes)(addr) if addr else None
    return table[key]


class _GLReader:
    """glGetIntegerv / glGetInteger64v / glGetIntegeri_v that return None on a GL error."""

    def __init__(self, ctx):
        c_int_p = ctypes.POINTER(ctypes.c_int)
        c_i64_p = ctypes.POINTER(ctypes.c_int64)
        self.get_error = gl_function(ctx, "glGetError", ctypes.c_uint)
        self.get_int = gl_function(ctx, "glGetIntegerv", None, ctypes.c_uint, c_int_p)
        self.get_int64 = gl_function(ctx, "glGetInteger64v", None, ctypes.c_uint, c_i64_p)
        self.get_int_i = gl_function(ctx, "glGetIntegeri_v", None, ctypes.c_uint, ctypes.c_uint, c_int_p)
        self.get_string = gl_function(ctx, "glGetString", ctypes.c_char_p, ctypes.c_uint)
        self.ok = self.get_error is not None and self.get_int is not None
        if self.ok:
            self._drain()

    def _drain(self):
        for _ in range(16):
            if self.get_error() == _GL_NO_ERROR:
                break

    def _call(self, fn, *args, count=1, ctype=ctypes.c_int):
        if not self.ok or fn is None:
            return None
        out = (ctype * max(count, 4))(*([-1] * max(count, 4)))
        try:
            fn(*args, out)
        except Exception:
            return None
        if self.get_error() != _GL_NO_ERROR:
            self._drain()
            return None
        return [int(v) for v in out[:count]]

    def integer(self, pname: int, count: int = 1):
        v = self._call(self.get_int, pname, count=count)
        return None if v is None else (v[0] if count == 1 else tuple(v))

    def integer64(self, pname: int):
        v = self._call(self.get_int64, pname, ctype=ctypes.c_int64)
        return None if v is None else v[0]

    def indexed(self, pname: int, n: int):
        vals = []
        for i in range(n):
            v = self._call(self.get_int_i, pname, i)
            if v is None:
                return None
            vals.append(v[0])
        return tuple(vals)

    def string(self, name: int):
        if not self.ok or self.get_string is None:
            return None
        try:
            s = self.get_string(name)
        except Exception:
            return None
        if self.get_error() != _GL_NO_ERROR:
            self._drain()
            return None
        return s.decode(errors="replace") if s else None


# --------------------------------------------------------------------------- limits

# key -> (GL name, enum, kind); kind: "int", "int64" or "indexed3"
LIMITS: dict[str, tuple[str, int, str]] = {
    "max_tess_gen_level": ("GL_MAX_TESS_GEN_LEVEL", 0x8E7E, "int"),
    "max_patch_vertices": ("GL_MAX_PATCH_VERTICES", 0x8E7D, "int"),
    "max_compute_work_group_count": ("GL_MAX_COMPUTE_WORK_GROUP_COUNT", 0x91BE, "indexed3"),
    "max_compute_work_group_size": ("GL_MAX_COMPUTE_WORK_GROUP_SIZE", 0x91BF, "indexed3"),
    "max_compute_work_group_invocations": ("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", 0x90EB, "int"),
    "max_compute_shared_memory_size": ("GL_MAX_COMPUTE_SHARED_MEMORY_SIZE", 0x8262, "int"),
    "max_shader_storage_block_size": ("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 0x90DE, "int64"),
    "max_shader_storage_buffer_bindings": ("GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS", 0x90DD, "int"),
    "max_compute_shader_storage_blocks": ("GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS", 0x90DB, "int"),
    "max_fragment_shader_storage_blocks": ("GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS", 0x90DA, "int"),
    "max_image_units": ("GL_MAX_IMAGE_UNITS", 0x8F38, "int"),
    "max_texture_size": ("GL_MAX_TEXTURE_SIZE", 0x0D33, "int"),
    "max_3d_texture_size": ("GL_MAX_3D_TEXTURE_SIZE", 0x8073, "int"),
    "max_samples": ("GL_MAX_SAMPLES", 0x8D57, "int"),
    "max_draw_buffers": ("GL_MAX_DRAW_BUFFERS", 0x8824, "int"),
    "max_color_attachments": ("GL_MAX_COLOR_ATTACHMENTS", 0x8CDF, "int"),
    "max_geometry_output_vertices": ("GL_MAX_GEOMETRY_OUTPUT_VERTICES", 0x8DE0, "int"),
    "max_geometry_total_output_components": ("GL_MAX_GEOMETRY_TOTAL_OUTPUT_COMPONENTS", 0x8DE1, "int"),
    "max_vertex_attribs": ("GL_MAX_VERTEX_ATTRIBS", 0x8869, "int"),
    "max_uniform_block_size": ("GL_MAX_UNIFORM_BLOCK_SIZE", 0x8A30, "int64"),
}
# GL_KHR_shader_subgroup's values, read where the extension is: invocations a subgroup, the
# stages (bits: compute 0x20) and features (basic 0x1, arithmetic 0x4) that have them
SUBGROUP = {"size": 0x9532, "stages": 0x9533, "features": 0x9534}

# Extensions that change what mane can do (a core feature is judged by the version instead).
EXTENSIONS_THAT_MATTER = (
    "GL_ARB_compute_shader",
    "GL_ARB_tessellation_shader",
    "GL_ARB_shader_storage_buffer_object",
    "GL_ARB_shader_image_load_store",
    "GL_ARB_shader_atomic_counters",
    "GL_ARB_timer_query",
    "GL_ARB_gpu_shader_int64",
    "GL_AMD_gpu_shader_int64",
    "GL_NV_gpu_shader5",
    "GL_NV_shader_atomic_int64",
    "GL_NV_shader_atomic_float",
    "GL_ARB_shader_ballot",
    "GL_KHR_shader_subgroup",
    "GL_ARB_fragment_shader_interlock",
    "GL_NV_fragment_shader_interlock",
    "GL_INTEL_fragment_shader_ordering",
    "GL_NV_mesh_shader",
    "GL_ARB_bindless_texture",
    "GL_ARB_gl_spirv",
    "GL_NVX_gpu_memory_info",
    "GL_ATI_meminfo",
)

# GL_NVX_gpu_memory_info (values in KiB)
GPU_MEMORY_INFO_DEDICATED_VIDMEM_NVX = 0x9047
GPU_MEMORY_INFO_TOTAL_AVAILABLE_MEMORY_NVX = 0x9048
GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX = 0x9049
# GL_ATI_meminfo (4 values in KiB; the first is the free total)
VBO_FREE_MEMORY_ATI = 0x87FB
TEXTURE_FREE_MEMORY_ATI = 0x87FC
GL_SHADING_LANGUAGE_VERSION = 0x8B8C


@dataclass(frozen=True)
class GPUMemory:
    """GPU memory in bytes, as far as the driver says; ``source`` says who said it."""

    total: int | None
    available: int | None
    source: str  # "GL_NVX_gpu_memory_info", "GL_ATI_meminfo", "system RAM (software renderer)", "unknown"

    def as_dict(self) -> dict:
        return {"total": self.total, "available": self.available, "source": self.source}


def system_ram() -> tuple[int | None, int | None]:
    total = avail = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                key, _, rest = line.partition(":")
                if key in ("MemTotal", "MemAvailable"):
                    kib = int(rest.split()[0]) * 1024
                    if key == "MemTotal":
                        total = kib
                    else:
                        avail = kib
    except (OSError, ValueError, IndexError):
        try:
            total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (ValueError, OSError, AttributeError):
            pass
    return total, avail


def gpu_memory(ctx, extensions=None, software: bool | None = None) -> GPUMemory:
    """Total and currently available memory, read now (it changes as buffers are made)."""
    exts = set(ctx.extensions) if extensions is None else extensions
    soft = is_software_renderer(ctx) if software is None else software
    with _current(ctx):
        reader = _GLReader(ctx)
        if "GL_NVX_gpu_memory_info" in exts:
            total = reader.integer(GPU_MEMORY_INFO_TOTAL_AVAILABLE_MEMORY_NVX)
            avail = reader.integer(GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX)
            if total is not None or avail is not None:
                return GPUMemory(None if total is None else total * 1024,
                                 None if avail is None else avail * 1024, "GL_NVX_gpu_memory_info")
        if "GL_ATI_meminfo" in exts:
            free = reader.integer(VBO_FREE_MEMORY_ATI, count=4)
            if free is not None:
                return GPUMemory(None, free[0] * 1024, "GL_ATI_meminfo")
    if soft:  # llvmpipe's "GPU memory" is the machine's RAM
        total, avail = system_ram()
        if total is not None or avail is not None:
            return GPUMemory(total, avail, "system RAM (software renderer)")
    return GPUMemory(None, None, "unknown")


class _EGL:
    """The few libEGL calls needed to switch contexts and put the caller's back."""

    _lib = None

    @classmethod
    def lib(cls):
        if cls._lib is None:
            cls._lib = False
            for name in egl_library_names():
                if not name:
                    continue
                try:
                    lib = ctypes.CDLL(name)
                    for fn in ("eglGetCurrentContext", "eglGetCurrentDisplay"):
                        getattr(lib, fn).restype = ctypes.c_void_p
                    lib.eglGetCurrentSurface.restype = ctypes.c_void_p
                    lib.eglGetCurrentSurface.argtypes = [ctypes.c_int]
                    lib.eglMakeCurrent.restype = ctypes.c_uint
                    lib.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
                    cls._lib = lib
                    break
                except (OSError, AttributeError):
                    continue
        return cls._lib or None


class _current:
    """Make an EGL context current for the block, and afterwards put back the one that was.

    moderngl's ``with ctx:`` is no use here: on leaving, glcontext's EGL backend makes *no*
    context current, which breaks the next moderngl call. If no context was current
    before, ``ctx`` stays current. Contexts of other backends (a window's GLX/WGL one)
    are assumed to be current already, as moderngl itself assumes.
    """

    EGL_DRAW, EGL_READ = 0x3059, 0x305A

    def __init__(self, ctx):
        self.ctx = ctx
        self.restore = None

    def __enter__(self):
        glc = getattr(getattr(self.ctx, "mglo", None), "_context", None)
        egl = _EGL.lib()
        if glc is None or egl is None or type(glc).__module__.split(".")[-1] != "egl":
            return self
        try:
            prev = (egl.eglGetCurrentDisplay(), egl.eglGetCurrentSurface(self.EGL_DRAW),
                    egl.eglGetCurrentSurface(self.EGL_READ), egl.eglGetCurrentContext())
            glc.__enter__()
            if prev[3] and egl.eglGetCurrentContext() != prev[3]:
                self.restore = prev
        except Exception:
            self.restore = None
        return self

    def __exit__(self, *exc):
        if self.restore is not None:
            try:
                _EGL.lib().eglMakeCurrent(*self.restore)
            except Exception:
                pass
        return False


def _read_limits(ctx, reader: _GLReader) -> dict:
    info = ctx.info
    limits: dict = {}
    for key, (gl_name, enum, kind) in LIMITS.items():
        value = info.get(gl_name)
        if value is None:
            if kind == "int":
                value = reader.integer(enum)
            elif kind == "int64":
                value = reader.integer64(enum)
                if value is None:
                    value = reader.integer(enum)
            else:
                value = reader.indexed(enum, 3)
        if isinstance(value, (list, tuple)):
            value = [int(v) for v in value]
        elif value is not None:
            value = int(value)
        limits[key] = value
    return limits


# --------------------------------------------------------------------------- features

@dataclass(frozen=True)
class Feature:
    """One of mane's features on this context: available, and if not, why and what to do."""

    name: str
    label: str
    available: bool
    reason: str = ""  # what is there or missing
    hint: str = ""    # what to do when it is missing

    def as_dict(self) -> dict:
        return {"available": self.available, "reason": self.reason}


GPU_DRIVER_HINT = "run on a GPU with a current driver (NVIDIA: the proprietary driver with libegl1)"


def _version_str(code: int) -> str:
    return f"{code // 100}.{code % 100 // 10}"


def _features(version: int, exts: frozenset, limits: dict, software: bool) -> dict[str, Feature]:
    def lim(key, default=0):
        v = limits.get(key)
        return default if v is None else v

    out: dict[str, Feature] = {}

    def add(name, label, ok, reason, hint=""):
        out[name] = Feature(name, label, bool(ok), reason, "" if ok else hint)

    # compute simulation: GL 4.3 compute shaders writing SSBOs
    if version >= 430 or "GL_ARB_compute_shader" in exts:
        ok = lim("max_compute_work_group_invocations") >= 64 and lim("max_shader_storage_buffer_bindings") >= 8
        add("compute_simulation", "compute simulation", ok,
            f"compute shaders, {lim('max_compute_work_group_invocations')} invocations/group, "
            f"{lim('max_shader_storage_buffer_bindings')} SSBO bindings" if ok else
            "compute shaders present but fewer than 64 invocations or 8 SSBO bindings",
            GPU_DRIVER_HINT)
    else:
        add("compute_simulation", "compute simulation", False,
            f"OpenGL {_version_str(version)} has no compute shaders (needs 4.3)", GPU_DRIVER_HINT)

    tess_ok = (version >= 400 or "GL_ARB_tessellation_shader" in exts) and lim("max_tess_gen_level") >= 16 \
        and lim("max_patch_vertices") >= 4
    add("tessellated_strands", "tessellated strands", tess_ok,
        f"tessellation up to level {lim('max_tess_gen_level')}, {lim('max_patch_vertices')} patch vertices"
        if tess_ok else f"no usable tessellation (OpenGL {_version_str(version)}, "
                        f"max level {limits.get('max_tess_gen_level')})",
        "render strands as line strips (no tessellation) or " + GPU_DRIVER_HINT)

    geo_ok = version >= 320 and lim("max_geometry_output_vertices") >= 16
    add("geometry_ribbons", "geometry ribbons", geo_ok,
        f"geometry shaders, {lim('max_geometry_output_vertices')} output vertices" if geo_ok else
        "no geometry shaders with 16 output vertices", "expand ribbons in a compute pass instead")

    img_ok = (version >= 430 or {"GL_ARB_shader_image_load_store", "GL_ARB_shader_storage_buffer_object"} <= exts) \
        and lim("max_fragment_shader_storage_blocks") >= 1
    add("image_atomics", "image atomics / A-buffer", img_ok,
        "image load/store and SSBO atomics in fragment shaders" if img_ok else
        "no image load/store or no SSBOs in fragment shaders",
        "use sorted-free alpha blending (no order-independent transparency)")

    int64 = next((e for e in ("GL_ARB_gpu_shader_int64", "GL_NV_gpu_shader5", "GL_AMD_gpu_shader_int64") if e in exts), None)
    atomic64 = "GL_NV_shader_atomic_int64" in exts
    if int64 and atomic64:
        add("kbuffer_int64", "64-bit atomic K-buffer", True, f"{int64} + GL_NV_shader_atomic_int64")
    else:
        missing = [m for m, have in (("GL_ARB_gpu_shader_int64 (64-bit integers)", int64),
                                     ("GL_NV_shader_atomic_int64 (64-bit atomics)", atomic64)) if not have]
        add("kbuffer_int64", "64-bit atomic K-buffer", False, "missing " + " and ".join(missing),
            "mane uses the 32-bit A-buffer instead; the 64-bit K-buffer needs an NVIDIA GPU")

    interlock = next((e for e in ("GL_ARB_fragment_shader_interlock", "GL_NV_fragment_shader_interlock",
                                  "GL_INTEL_fragment_shader_ordering") if e in exts), None)
    add("fragment_interlock", "fragment shader interlock", interlock is not None,
        interlock or "no GL_ARB_fragment_shader_interlock, GL_NV_fragment_shader_interlock "
                      "or GL_INTEL_fragment_shader_ordering" + (" (Mesa llvmpipe has none)" if software else ""),
        "mane falls back to the atomic A-buffer; interlock needs an NVIDIA (Maxwell+) or Intel GPU")

    add("nv_mesh_shader", "NV mesh shaders", "GL_NV_mesh_shader" in exts,
        "GL_NV_mesh_shader" if "GL_NV_mesh_shader" in exts else "no GL_NV_mesh_shader",
        "strands are drawn with tessellation or geometry shaders instead; mesh shaders need NVIDIA Turing or newer")

    has_timer = version >= 330 or "GL_ARB_timer_query" in exts
    if has_timer and software:
        add("timer_queries", "GPU timer queries", False,
            "software renderer: GL_TIME_ELAPSED reads ~1 ns around compute and garbage around draws",
            "the profiler times passes on the CPU (glFinish + perf_counter) instead")
    else:
        add("timer_queries", "GPU timer queries", has_timer,
            "GL_ARB_timer_query" if has_timer else "no GL_ARB_timer_query",
            "the profiler times passes on the CPU (glFinish + perf_counter) instead")

    samples = lim("max_samples")
    add("msaa_8x", "MSAA 8x", samples >= 8, f"max samples {samples}",
        f"use {samples}x MSAA or supersampling" if samples else "use supersampling")

    float_ok = version >= 300 and lim("max_color_attachments") >= 4
    add("float_render_targets", "float render targets", float_ok,
        f"RGBA16F/RGBA32F colour attachments, {lim('max_color_attachments')} attachments" if float_ok else
        "no float colour attachments or fewer than 4 attachments", GPU_DRIVER_HINT)
    return out


FEATURES = ("compute_simulation", "tessellated_strands", "geometry_ribbons", "image_atomics",
            "kbuffer_int64", "fragment_interlock", "nv_mesh_shader", "timer_queries",
            "msaa_8x", "float_render_targets")

# --------------------------------------------------------------------------- capabilities


@dataclass(frozen=True)
class Capabilities:
    renderer: str
    vendor: str
    version: str        # GL_VERSION, e.g. "4.5 (Core Profile) Mesa 22.3.6"
    version_code: int   # 450
    glsl_version: str   # "4.50"
    is_software: bool
    extensions: frozenset = field(hash=False, repr=False)
    limits: dict = field(hash=False, compare=False)
    memory: GPUMemory = field(hash=False, compare=False)
    features: dict = field(hash=False, compare=False, repr=False)
    subgroup: dict = field(default_factory=dict, hash=False, compare=False)   # SUBGROUP's values; {} without it

    @classmethod
    def query(cls, ctx) -> "Capabilities":
        """Read everything from ``ctx`` (made current for the duration when it is headless)."""
        info = ctx.info
        exts = frozenset(ctx.extensions)
        software = is_software_renderer(ctx)
        with _current(ctx):
            reader = _GLReader(ctx)
            limits = _read_limits(ctx, reader)
            subgroup = ({k: reader.integer(enum) for k, enum in SUBGROUP.items()}
                        if "GL_KHR_shader_subgroup" in exts else {})
            glsl = reader.string(GL_SHADING_LANGUAGE_VERSION)
        memory = gpu_memory(ctx, exts, software)
        if not glsl:
            glsl = _version_str(ctx.version_code) + "0"
        return cls(
            renderer=renderer_name(ctx),
            vendor=str(info.get("GL_VENDOR", "unknown")),
            version=str(info.get("GL_VERSION", _version_str(ctx.version_code))),
            version_code=int(ctx.version_code),
            glsl_version=glsl.split()[0] if glsl else "",
            is_software=software,
            extensions=exts,
            limits=limits,
            memory=memory,
            features=_features(int(ctx.version_code), exts, limits, software),
            subgroup=subgroup,
        )

    def has_extension(self, name: str) -> bool:
        return name in self.extensions

    def extensions_that_matter(self) -> dict[str, bool]:
        return {name: name in self.extensions for name in EXTENSIONS_THAT_MATTER}

    def available(self, feature: str) -> bool:
        return self._feature(feature).available

    def _feature(self, feature: str) -> Feature:
        try:
            return self.features[feature]
        except KeyError:
            raise GLFeatureError(f"unknown feature {feature!r}; known: {', '.join(self.features)}") from None

    def require(self, feature: str) -> None:
        """Raise GLFeatureError, saying what is missing and what to do, unless ``feature`` is there."""
        f = self._feature(feature)
        if not f.available:
            what = f" What to do: {f.hint}." if f.hint else ""
            raise GLFeatureError(f"{f.label} is not available on {self.renderer} "
                                 f"(OpenGL {self.version}): {f.reason}.{what}")

    def as_dict(self) -> dict:
        """JSON-ready, in the shape ``mane doctor --json`` prints."""
        return {
            "renderer": self.renderer,
            "vendor": self.vendor,
            "version": self.version,
            "version_code": self.version_code,
            "glsl_version": self.glsl_version,
            "software": self.is_software,
            "extensions": self.extensions_that_matter(),
            "limits": dict(self.limits),
            "memory": self.memory.as_dict(),
            "features": {name: f.as_dict() | {"label": f.label, "hint": f.hint} for name, f in self.features.items()},
        }


_cached: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def get_capabilities(ctx) -> Capabilities:
    """``Capabilities.query(ctx)``, cached per context (its memory figure is from the first call)."""
    caps = _cached.get(ctx)
    if caps is None:
        caps = _cached[ctx] = Capabilities.query(ctx)
    return caps


def has_atomic64(ctx) -> bool:
    """64-bit integer atomics on shader storage (GL_NV_shader_atomic_int64 + 64-bit ints)."""
    return get_capabilities(ctx).available("kbuffer_int64")
