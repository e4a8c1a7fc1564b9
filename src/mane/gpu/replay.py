"""A frame's GL calls recorded once and issued again without the Python that made them.

A renderer's frame is a few hundred lines of Python (passes choosing programs, binding buffers
and images, setting uniforms) that end in ~120 GL calls through moderngl. While nothing the
frame is made of changes (the camera, the lights, the settings, the renderer's objects), those
Python decisions come out the same every frame; only the GPU's data move (a simulator writing
the hair). ``record()`` runs a frame with moderngl's calls captured (each call's function and
arguments, GL objects by reference, data by value); ``Recording.play()`` issues the same calls
in the same order: the driver sees the same commands, so the frame is the same, bit for bit.
render/frame_replay.py decides when a recording may stand in for a frame.

What a recording cannot hold makes it ``side`` (the frame is drawn, the recording is not used):
a call whose result the Python reads (buffer and texture reads, a finish, fences: marked with
``side()`` by gpu/fence.py), a GL object made or released during the frame. Timer queries are
not recorded (a played frame is not timed); what the scan-form tuner decides from their results
it decides in the frame it reads them, so that frame's calls show it. Code that keeps per-frame
state (a counter that makes every Nth frame different: the scan-form tuner's timed frames, the
tiled raster's peak check) registers ``each_frame(ready, advance)``: before a recording is
played, ``ready()`` says whether this frame would come out as recorded, and ``advance()`` moves
the state as the skipped frame would have.

moderngl's classes are patched only while a frame is recorded (one at a time in a process), and
only the recording thread's calls are kept; calls made inside a recorded call (moderngl's own)
are not recorded again.
"""
from __future__ import annotations

import threading
from functools import partial
from threading import get_ident

import moderngl
import numpy as np

# GL calls that only issue commands or set state (no result the caller reads): recorded
_RECORD = {
    "Context": ("clear", "enable_only", "enable", "disable", "enable_direct", "disable_direct",
                "copy_buffer", "copy_framebuffer", "memory_barrier", "clear_samplers"),
    "Buffer": ("write", "write_chunks", "clear", "bind_to_uniform_block", "bind_to_storage_buffer", "orphan"),
    "Texture": ("write", "build_mipmaps", "use", "bind_to_image"),
    "TextureArray": ("write", "build_mipmaps", "use", "bind_to_image"),
    "Texture3D": ("write", "build_mipmaps", "use", "bind_to_image"),
    "TextureCube": ("write", "build_mipmaps", "use", "bind_to_image"),
    "ComputeShader": ("run", "run_indirect"),
    "Program": ("draw_mesh_tasks", "draw_mesh_tasks_indirect", "draw_mesh_tasks_indirect_count"),
    "Uniform": ("write",),
    "Framebuffer": ("clear", "use"),
    "VertexArray": ("render", "render_indirect", "transform"),
    "Sampler": ("use", "clear"),
}
# calls whose result the caller reads, or that make or free GL objects: a frame with one is not replayed
_SIDE = {
    "Context": ("finish", "detect_framebuffer", "buffer", "external_buffer", "external_texture", "texture", "texture_array",
                "texture3d", "texture_cube", "depth_texture", "depth_texture_cube", "vertex_array",
                "simple_vertex_array", "program", "query", "scope", "simple_framebuffer", "framebuffer",
                "empty_framebuffer", "renderbuffer", "depth_renderbuffer", "compute_shader", "sampler", "release",
                "clear_errors", "gc"),
    "Buffer": ("read", "read_into", "read_chunks", "read_chunks_into", "release"),
    "Texture": ("read", "read_into", "get_handle", "release"),
    "TextureArray": ("read", "read_into", "get_handle", "release"),
    "Texture3D": ("read", "read_into", "get_handle", "release"),
    "TextureCube": ("read", "read_into", "get_handle", "release"),
    "ComputeShader": ("release",),
    "Program": ("release",),
    "Uniform": ("read",),
    "Framebuffer": ("read", "read_into", "release"),
    "Renderbuffer": ("release",),
    "VertexArray": ("release",),
    "Sampler": ("release",),
    "Scope": ("release",),
}
_DATA = (bytearray, memoryview)   # arguments copied when recorded (the caller may change them after), and arrays
_COPY = frozenset({*_DATA, np.ndarray})
_BINDS: dict = {}   # the recorded functions that bind one unit or point -> its kind (Recording.pruned)
_KEEPS: set = set()   # recorded functions that change no binding pruned follows


class Recording:
    """A frame's calls (``calls``: partials, issued in order by ``play``), the per-frame hooks
    registered while it was made (``hooks``: (ready, advance) pairs) and ``side``: why it
    cannot stand in for a frame (None: it can)."""

    def __init__(self):
        self.calls: list[partial] = []
        self.hooks: list[tuple] = []
        self.side: str | None = None
        self.thread = get_ident()
        self.depth = 0

    def play(self) -> None:
        for call in self.calls:
            call()

    def pruned(self) -> "Recording":
        """The same frame without the binds that bind again, within the frame, what that unit
        or binding point holds already (a pass binding what the pass before it bound: ~20 of
        the target frame's ~120 calls). Only texture units, image units, storage-buffer binding
        points and the framebuffer are followed; any other call but a dispatch or a barrier
        forgets what is known of the framebuffer and the texture units (moderngl binds a texture
        to a unit of its own to write it or build its mipmaps, and a clear or a copy may leave
        another framebuffer bound), and the first bind of each in the frame always stays, as
        the frame cannot know what the frame before it left bound."""
        out = Recording()
        out.hooks, out.side = self.hooks, self.side
        bound: dict = {}
        for call in self.calls:
            kind = _BINDS.get(call.func)
            if kind is None:
                if call.func not in _KEEPS:
                    for k in [k for k in bound if k[0] in ("fbo", "tex")]:
                        del bound[k]
                out.calls.append(call)
                continue
            a = call.args
            if kind == "fbo":
                slot, what = ("fbo",), (a[0],)
            else:
                slot = (kind, a[1] if len(a) > 1 else call.keywords.get("location" if kind == "tex" else "binding",
                                                                           call.keywords.get("unit", 0)))
                what = (a[0], *a[2:], *sorted(call.keywords.items()))
            if bound.get(slot) == what:
                continue
            bound[slot] = what
            out.calls.append(call)
        return out

    def ready(self) -> bool:
        """Whether every hook says the next frame comes out as recorded."""
        return all(ready() for ready, _ in self.hooks)

    def advance(self) -> None:
        for _, advance in self.hooks:
            advance()

    def difference(self, other: "Recording") -> str | None:
        """None when the two make the same calls with the same arguments; else where they first
        differ, in words. GL objects compare by identity (moderngl defines no equality), values
        by ``==``, data as bytes."""
        a, b = self.calls, other.calls
        for i, (x, y) in enumerate(zip(a, b)):
            if x.func is not y.func or x.args != y.args or x.keywords != y.keywords:
                return f"call {i}: {_describe(x)} against {_describe(y)}"
        if len(a) != len(b):
            n = min(len(a), len(b))
            extra = _describe((a if len(a) > n else b)[n])
            return f"{len(a)} calls against {len(b)}, from call {n}: {extra}"
        return None


def _describe(call: partial) -> str:
    name = getattr(call.func, "__qualname__", repr(call.func))
    args = ", ".join(type(a).__name__ if type(a).__module__.startswith("moderngl") else repr(a)[:40]
                     for a in call.args)
    return f"{name}({args})"


_active: Recording | None = None
_lock = threading.Lock()   # held while a frame is recorded (moderngl's classes patched)


class record:
    """``with record() as rec:`` the GL calls of the block, in ``rec``. One frame is recorded at
    a time in a process: while another thread records, ``rec`` is None (``strict``: RuntimeError)."""

    def __init__(self, strict: bool = True):
        self.strict = strict
        self.rec = None

    def __enter__(self) -> Recording | None:
        global _active
        if not _lock.acquire(blocking=False):
            if self.strict:
                raise RuntimeError("a frame is being recorded already")
            return None
        self.rec = _active = Recording()
        _patch()
        return self.rec

    def __exit__(self, *exc) -> None:
        global _active
        if self.rec is not None:
            try:
                _unpatch()
            finally:
                _active = None
                _lock.release()


def side(reason: str) -> None:
    """A GL call outside moderngl (ctypes: queries, fences) whose result the frame reads: the
    frame being recorded, if any, cannot be replayed."""
    rec = _active
    if rec is not None and rec.side is None and rec.thread == get_ident():
        rec.side = reason


def each_frame(ready, advance) -> None:
    """Per-frame state kept outside the GL calls: ``ready()`` -> whether the next frame comes out
    as the recording does; ``advance()`` moves the state as that frame would have (when played)."""
    rec = _active
    if rec is not None and rec.thread == get_ident():
        rec.hooks.append((ready, advance))


def _recorded(fn):
    def call(*args, **kwargs):
        rec = _active
        if rec is None or rec.depth or rec.thread != get_ident():
            return fn(*args, **kwargs)
        rec.depth = 1   # (a call that raises ends the frame, and its recording with it)
        out = fn(*args, **kwargs)
        rec.depth = 0
        for a in args:
            if a.__class__ in _COPY:
                args = tuple(map(_frozen, args))
                break
        if kwargs:
            kwargs = {k: _frozen(v) for k, v in kwargs.items()}
        rec.calls.append(partial(fn, *args, **kwargs))
        return out
    return call


def _frozen(value):
    """An argument as the recording keeps it: data the caller may change after (a bytearray, a
    NumPy array) as bytes."""
    if isinstance(value, _DATA):
        return bytes(value)
    if isinstance(value, np.ndarray):
        return bytes(value) if value.ndim else value.item()
    return value


def _setter(prop: property):
    def fset(self, value, _set=prop.fset):
        rec = _active
        if rec is None or rec.depth or rec.thread != get_ident():
            return _set(self, value)
        rec.depth = 1
        _set(self, value)
        rec.depth = 0
        rec.calls.append(partial(_set, self, _frozen(value)))
    return property(prop.fget, fset, prop.fdel, prop.__doc__)


def _marks_side(fn, name: str):
    def call(*args, **kwargs):
        rec = _active
        if rec is not None and not rec.depth and rec.side is None and rec.thread == get_ident():
            rec.side = name
        return fn(*args, **kwargs)
    return call


_TABLE: list[tuple] | None = None   # (class, name, original, patched)


def _table() -> list[tuple]:
    global _TABLE
    if _TABLE is None:
        out = []
        for cls_name, names in _RECORD.items():
            cls = getattr(moderngl, cls_name, None)
            for name in names if cls is not None else ():
                fn = cls.__dict__.get(name)
                if fn is not None:
                    out.append((cls, name, fn, _recorded(fn)))
        for cls_name, names in _SIDE.items():
            cls = getattr(moderngl, cls_name, None)
            for name in names if cls is not None else ():
                fn = cls.__dict__.get(name)
                if fn is not None:
                    out.append((cls, name, fn, _marks_side(fn, f"{cls_name}.{name}")))
        for cls_name in ("Context", "Texture", "TextureArray", "Texture3D", "TextureCube", "Framebuffer",
                         "VertexArray", "Sampler", "Uniform", "UniformBlock", "StorageBlock"):
            cls = getattr(moderngl, cls_name, None)
            for name, attr in (vars(cls).items() if cls is not None else ()):
                if isinstance(attr, property) and attr.fset is not None:
                    out.append((cls, name, attr, _setter(attr)))
        _TABLE = out
        textures = tuple(getattr(moderngl, n) for n in ("Texture", "TextureArray", "Texture3D", "TextureCube")
                         if hasattr(moderngl, n))
        for cls, name, original, _ in out:
            if cls is moderngl.Framebuffer and name == "use":
                _BINDS[original] = "fbo"
            elif cls in textures and name in ("use", "bind_to_image"):
                _BINDS[original] = "tex" if name == "use" else "img"
            elif cls is moderngl.Buffer and name == "bind_to_storage_buffer":
                _BINDS[original] = "ssbo"
            elif name in ("run", "run_indirect", "memory_barrier"):
                _KEEPS.add(original)
    return _TABLE


def _patch() -> None:
    for cls, name, _, patched in _table():
        setattr(cls, name, patched)


def _unpatch() -> None:
    for cls, name, original, _ in _table():
        setattr(cls, name, original)
