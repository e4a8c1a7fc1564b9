"""Core OpenGL entry points that moderngl 5 does not wrap (fences, layered framebuffers), found
through glvnd's libOpenGL / libGL, else eglGetProcAddress; cached by name.

    fence = gl_entry("glFenceSync", ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint)   # None: absent
"""
from __future__ import annotations

import ctypes

LIBRARIES = ("libOpenGL.so.0", "libGL.so.1", "libGL.so")
_cache: dict[str, object] = {}


def gl_entry(name: str, restype, *argtypes):
    """The entry point ``name`` as a ctypes function with these types, or None where no loader
    has it."""
    if name in _cache:
        return _cache[name]
    fn = None
    for lib in LIBRARIES:
        try:
            fn = getattr(ctypes.CDLL(lib), name)
            break
        except (OSError, AttributeError):
            continue
    if fn is None:
        try:
            egl = ctypes.CDLL("libEGL.so.1")
            egl.eglGetProcAddress.restype = ctypes.c_void_p
            egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
            addr = egl.eglGetProcAddress(name.encode())
            fn = ctypes.CFUNCTYPE(restype, *argtypes)(addr) if addr else None
        except OSError:
            fn = None
    if fn is not None:
        fn.restype, fn.argtypes = restype, list(argtypes)
    _cache[name] = fn
    return fn
