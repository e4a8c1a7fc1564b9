"""OpenGL contexts: headless through EGL, or the window's that is current.

    ctx = mane.gpu.get_context()      # the window's if one is current, else a shared headless one

Mesa's llvmpipe gives a full OpenGL 4.5 on machines without a GPU; an NVIDIA driver
gives 4.6. Anything below 4.3 (macOS stops at 4.1) cannot run compute shaders and is
refused with a message that says what to install.
"""
from __future__ import annotations

import threading
import weakref

from ..errors import GLFeatureError, GPUError

MIN_GL_VERSION = 430

_lock = threading.Lock()
_headless = None
_parking: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # context -> its 1x1 framebuffer

HOW_TO_GET_GL = (
    "mane needs OpenGL 4.3 core through EGL. On Debian/Ubuntu without a GPU: "
    "sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri (Mesa's llvmpipe gives OpenGL 4.5 on the CPU). "
    "With an NVIDIA GPU: install the driver and libegl1 (glvnd). macOS stops at OpenGL 4.1 and cannot run mane's compute shaders."
)


EGL_LIBRARIES = {"libgl": "libGL.so.1", "libegl": "libEGL.so.1"}
"""The libraries glcontext's EGL backend loads, named: without names it asks
``ctypes.util.find_library`` for each on every attempt (``ldconfig -p`` in a subprocess, and
where that misses a C compiler and the linker)."""


def _egl_libraries(backend: str) -> dict:
    """glcontext's ``libgl`` and ``libegl`` for the EGL backend: the usual names where both load
    (and no GLCONTEXT_LINUX_LIBGL / _LIBEGL setting names others), else nothing (its own search)."""
    import ctypes
    import os

    if backend != "egl" or os.environ.get("GLCONTEXT_LINUX_LIBGL") or os.environ.get("GLCONTEXT_LINUX_LIBEGL"):
        return {}
    try:
        for name in EGL_LIBRARIES.values():
            ctypes.CDLL(name)
    except OSError:
        return {}
    return dict(EGL_LIBRARIES)


def headless_context(require: int = MIN_GL_VERSION, *, backend: str = "egl"):
    """A new standalone (window-less) context through EGL, OpenGL ``require`` core at least."""
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a hard dependency
        raise GPUError(f"moderngl is not installed ({exc}); pip install moderngl") from None
    # Drivers such as NVIDIA's give exactly the version asked for, so ask for the newest
    # first (4.6 brings what 4.3 lacks) and step down to ``require``.
    ctx, error = None, None
    libraries = _egl_libraries(backend)
    for version in [v for v in (460, 450, 440, 430) if v > require] + [require]:
        try:
            ctx = moderngl.create_context(standalone=True, backend=backend, require=version, **libraries)
            break
        except Exception as exc:
            error = exc
    if ctx is None:
        raise GLFeatureError(f"cannot create an OpenGL {require // 100}.{require % 100 // 10} "
                             f"context through {backend.upper()}: {error}. {HOW_TO_GET_GL}") from None
    if ctx.version_code < require:
        version = ctx.info.get("GL_VERSION", "?")
        ctx.release()
        raise GLFeatureError(f"OpenGL {version} is too old. {HOW_TO_GET_GL}")
    # A standalone moderngl context starts with no framebuffer of its own (ctx.fbo None) and
    # binds the last one used again whenever it makes a framebuffer, even once that one is
    # released: a GL_INVALID_OPERATION (glBindFramebuffer) each time, seen in the driver's debug
    # output (gpu.driver_log). A 1x1 framebuffer of the context's own is what the renderer and
    # the other users of framebuffers return to (they bind ctx.fbo again when done).
    park = ctx.framebuffer([ctx.renderbuffer((1, 1), 4)])
    park.use()
    _parking[ctx] = park
    return ctx


def get_context(require: int = MIN_GL_VERSION):
    """The current window's context if there is one, otherwise one shared headless context."""
    global _headless
    import moderngl

    window_ctx = None
    if _headless is None:
        try:
            window_ctx = moderngl.get_context()
        except Exception:
            window_ctx = None
    if window_ctx is not None:
        if window_ctx.version_code < require:
            raise GLFeatureError(f"the window's OpenGL {window_ctx.version_code} is below {require}. {HOW_TO_GET_GL}")
        return window_ctx
    with _lock:
        if _headless is None:
            _headless = headless_context(require)
        return _headless


def window_closed(window_ctx) -> None:
    """A window whose context ``get_context`` may have handed out has closed: forget that context
    (moderngl keeps it as its default, and ``get_context`` would hand out a dead context) and make
    the shared headless context current again if there is one."""
    import moderngl

    store = getattr(moderngl, "_store", None)   # moderngl 5.x keeps its default context here
    if store is not None and getattr(store, "default_context", None) is window_ctx:
        store.default_context = None
    if _headless is not None:
        try:
            _headless.__enter__()
        except Exception:   # a context that cannot be made current: the next use says why
            pass


def renderer_name(ctx) -> str:
    return str(ctx.info.get("GL_RENDERER", "unknown"))


def is_software_renderer(ctx) -> bool:
    """True for CPU rasterisers (Mesa llvmpipe, softpipe, swrast, SwiftShader)."""
    return is_software_name(renderer_name(ctx))


def is_software_name(name: str) -> bool:
    """Whether a GL_RENDERER string names a CPU rasteriser (is_software_renderer)."""
    name = (name or "").lower()
    return any(k in name for k in ("llvmpipe", "softpipe", "swrast", "swiftshader", "software"))
