"""What the order-independent transparency methods share.

A method (one module each beside this one) draws the hair after the opaque head, into its
own buffers, and composites the result over the HDR target:

    m = METHODS[name](renderer)
    m.run(frame)          # begin (clear, grow), fill (the hair draws), resolve (composite)
    m.bytes()             # GPU memory the method holds now (its buffers and targets)
    m.stats()             # {"oit": name, "oit_bytes": ..., method details}

GLSL: every hair draw of a method compiles ``oit_hair.frag`` (hair_main.glsl's shading, its
``main`` renamed, then ``oit_body.glsl``) with ``OIT_METHOD`` / ``OIT_STAGE`` / ``OIT_K``;
the method's ``store_*.glsl`` holds each stage's ``oit_main()``. The hair colour reaching a
store is premultiplied, times ``oit_opacity``. The resolves are full-screen fragment shaders
(``resolve_*.frag``) writing (premultiplied colour, 1 - transmittance), blended ONE,
ONE_MINUS_SRC_ALPHA over the HDR target; depth = linear view depth (m) along the camera axis.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...errors import GLFeatureError, GPUMemoryError, UsageError
from ...gpu.buffers import buffer as gpu_buffer
from ...gpu.buffers import check_allocation
from ...gpu.clear import fill_words
from ...gpu.glsl import compute_shader, program
from ...gpu.uniforms import write_uniform
from ..bindings import IMG_CLEAR
from ..coverage_lod import box_corners
from ..passes.base import HERE as PASSES_DIR
from ..passes.base import PASS_SHADE, RENDER_DIR, Frame, bind_lighting, draw_hair, hair_program, set_uniform

HERE = Path(__file__).resolve().parent
OIT_FRAG = HERE / "oit_hair.frag"
OIT_FRAG_450 = HERE / "oit_hair450.frag"
METHOD_IDS = {"sorted_blending": 1, "random_subsets": 2, "a_buffer": 3, "k_buffer": 4, "dbk_buffer": 5,
              "shortcut": 6}
END = 0xFFFFFFFF
MiB = 1024 * 1024

# Hunz (2016) Fig. 42, his 656x861 viewport; "MB" there is MiB (2^20 bytes)
HUNZ_VIEWPORT = (656, 861)
HUNZ_MEMORY_MIB = {
    "random_subsets": 34.47,   # k = 8 RGBA16 (his 16-bit depth textures not counted)
    "k_buffer": 36.63,         # k = 8 RGBA16 + a 4-byte counter per pixel
    "a_buffer": 150.46,        # 12,959,208 fragments x 12 B + 4 B/px heads
    "dbk_buffer": 59.25,       # 4,518,344 fragments + heads (53.86) + the opaque layer
    "sorted_blending": 0.0,    # no extra memory
}


class OitMethod:
    """One transparency method: GPU objects it owns, the hair draws and the composite."""

    name = "oit"
    method_id = 0
    stages: tuple[str, ...] = ()

    def __init__(self, renderer):
        self.r = renderer
        self.ctx = renderer.ctx
        self._objects: dict[str, tuple[object, int]] = {}   # name -> (GL object, bytes)
        self._fbos: dict = {}
        self._size = None
        self.frames = 0
        self.warnings: list[str] = []

    # ------------------------------------------------------------------ settings
    @property
    def settings(self):
        return self.r.settings

    @property
    def size(self) -> tuple[int, int]:
        return tuple(self.r.settings.render_size)

    @property
    def pixels(self) -> int:
        w, h = self.size
        return w * h

    @property
    def k(self) -> int:
        return int(self.settings.oit_k)

    # ------------------------------------------------------------------ allocations
    def _keep(self, key: str, obj, nbytes: int):
        old = self._objects.pop(key, None)
        if old is not None:
            old[0].release()
        self._objects[key] = (obj, int(nbytes))
        return obj

    def get(self, key: str):
        entry = self._objects.get(key)
        return None if entry is None else entry[0]

    def buffer(self, key: str, nbytes: int, what: str | None = None, host_read: bool = False):
        """An SSBO of ``nbytes`` (kept while the size stays), checked against GPU memory
        (``host_read``: gpu.buffers.buffer's)."""
        nbytes = max(16, int(nbytes))
        entry = self._objects.get(key)
        if entry is not None and entry[1] == nbytes:
            return entry[0]
        if entry is not None:
            entry[0].release()
            del self._objects[key]
        buf = gpu_buffer(self.ctx, nbytes, what or f"OIT {self.name} {key}", host_read=host_read)
        return self._keep(key, buf, nbytes)

    def texture(self, key: str, components: int, dtype: str, size=None):
        size = tuple(size or self.size)
        bpc = {"f1": 1, "f2": 2, "f4": 4, "u4": 4, "i4": 4}[dtype]
        nbytes = size[0] * size[1] * components * bpc
        entry = self._objects.get(key)
        if entry is not None and tuple(entry[0].size) == size and entry[0].components == components \
                and entry[0].dtype == dtype:
            return entry[0]
        check_allocation(self.ctx, nbytes, f"OIT {self.name} {key}", ssbo=False)
        tex = self.ctx.texture(size, components, dtype=dtype)
        tex.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        self._drop_fbos()
        return self._keep(key, tex, nbytes)

    def _drop_fbos(self):
        for f in self._fbos.values():
            f.release()
        self._fbos.clear()

    def fbo(self, key: str, colors: list, depth: bool = True):
        """A framebuffer of ``colors`` (textures) and, with ``depth``, the HDR target's depth
        (the head's: the fill passes test against it and never write it)."""
        depth_rb = self.r.hdr_target().depth if depth else None
        ident = (key, tuple(id(c) for c in colors), id(depth_rb))
        f = self._fbos.get(ident)
        if f is None:
            for k in [k for k in self._fbos if k[0] == key]:
                self._fbos.pop(k).release()
            f = self.ctx.framebuffer(color_attachments=list(colors), depth_attachment=depth_rb)
            self._fbos[ident] = f
        return f

    def clear_color(self, key: str, colors: list, value) -> None:
        """Clear colour textures (through a framebuffer without the head's depth, which stays)."""
        f = self.fbo("clear_" + key, colors, depth=False)
        f.use()
        f.clear(*value)

    def bytes(self) -> int:
        """GPU memory held by the method's buffers and targets now (bytes)."""
        return int(sum(n for _, n in self._objects.values()))

    def bytes_detail(self) -> dict:
        return {k: int(n) for k, (_, n) in self._objects.items()}

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel: float | None = None) -> int:
        """What the method allocates at ``size`` (default: the settings' render size)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ GL helpers
    def clear_buffer(self, buf, value: int, count: int | None = None) -> None:
        """The first ``count`` words (default all) of ``buf`` set to ``value``; the caller's
        barrier follows its clears."""
        fill_words(self.ctx, buf, int(value) & 0xFFFFFFFF, count=count, barrier=False)

    def clear_image(self, tex, value: int) -> None:
        cs = compute_shader(self.ctx, HERE / "clear.comp")
        tex.bind_to_image(IMG_CLEAR, read=False, write=True)
        write_uniform(cs["u_value"], int(value) & 0xFFFFFFFF)
        w, h = tex.size
        write_uniform(cs["u_size"], (w, h))
        gx, gy = _groups(w * h)
        cs.run(gx, gy, 1)

    def barrier(self) -> None:
        self.ctx.memory_barrier()
        self.ctx.finish()

    def hair_program(self, stage: int, glsl450: bool = False, **defines):
        d = {"OIT_METHOD": self.method_id, "OIT_STAGE": int(stage), "OIT_K": max(1, self.k)}
        d.update(defines)
        frag = OIT_FRAG_450 if glsl450 else OIT_FRAG
        return hair_program(self.r, PASS_SHADE, fragment_file=frag, extra_defines=d)

    def resolve_program(self, fragment: str, **defines):
        d = {"OIT_METHOD": self.method_id, "OIT_K": self.k}
        d.update(defines)
        return program(self.ctx, vertex=PASSES_DIR / "fullscreen.vert", fragment=HERE / fragment,
                       defines=d, include_dirs=[HERE, RENDER_DIR])

    def depth_range(self, frame: Frame) -> tuple[float, float]:
        """The hair's view depth range (m) this frame, from its padded bounding box."""
        r = self.r
        lo, hi = r.strands.bbox()
        pad = r.strand_pad() + float(self.settings.width)
        corners = box_corners(np.asarray(lo, float) - pad, np.asarray(hi, float) + pad)
        z = (corners - frame.view.eye) @ np.asarray(frame.view.forward, float)
        near = max(float(z.min()), 1e-4)
        return near, max(float(z.max()), near + 1e-3)

    def setup_hair(self, prog, frame: Frame) -> None:
        """Shading, lights and the OIT uniforms of a hair draw."""
        r = self.r
        r.shading.bind(prog, self.ctx, r.settings)
        bind_lighting(r, prog, frame)
        set_uniform(prog, "u_oit_opacity", float(self.settings.oit_opacity))
        set_uniform(prog, "u_oit_size", self.size)
        set_uniform(prog, "u_oit_depth_range", self.depth_range(frame))

    def draw(self, prog, frame: Frame, vao=None) -> None:
        if vao is None:
            draw_hair(self.r, prog, frame.view)
        else:
            draw_hair(self.r, prog, frame.view, vao=vao)

    def fill_state(self, fbo, *, blend=None, depth_write: bool = False) -> None:
        """Bind ``fbo`` for a hair draw: depth test against the head, no depth writes (unless
        asked), no face culling; ``blend`` a blend_func tuple or None (off)."""
        ctx = self.ctx
        fbo.use()
        fbo.depth_mask = bool(depth_write)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.disable(ctx.CULL_FACE)
        if blend is None:
            ctx.disable(ctx.BLEND)
        else:
            ctx.enable(ctx.BLEND)
            ctx.blend_func = blend

    def end_fill(self, fbo) -> None:
        fbo.depth_mask = True
        self.ctx.disable(self.ctx.BLEND)
        self.ctx.blend_func = (self.ctx.SRC_ALPHA, self.ctx.ONE_MINUS_SRC_ALPHA)

    def composite(self, prog) -> None:
        """Full-screen ``prog`` over the HDR target: ONE, ONE_MINUS_SRC_ALPHA, no depth."""
        ctx, r = self.ctx, self.r
        hdr = r.hdr_fbo()
        hdr.use()
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
        r.empty_vao(prog).render(ctx.TRIANGLES, vertices=3)
        ctx.disable(ctx.BLEND)
        ctx.blend_func = (ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA)
        ctx.enable(ctx.DEPTH_TEST)

    # ------------------------------------------------------------------ the frame
    def section(self, name: str):
        return self.r.profiler.section(f"oit.{name}")

    def run(self, frame: Frame) -> None:
        if self._size != self.size:
            self.resize()
            self._size = self.size
        with self.section("begin"):
            self.begin(frame)
        with self.section("fill"):
            self.fill(frame)
        self.barrier()
        with self.section("resolve"):
            self.resolve(frame)
        self.frames += 1

    def resize(self) -> None:
        """The render size changed (or first frame): (re)allocate size-dependent objects."""

    def begin(self, frame: Frame) -> None:
        pass

    def fill(self, frame: Frame) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def resolve(self, frame: Frame) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def stats(self) -> dict:
        return {"oit": self.name, "oit_bytes": self.bytes(), "oit_bytes_detail": self.bytes_detail(),
                "oit_k": self.k, "oit_warnings": list(self.warnings), "rasterizer": "hardware"}

    def release(self) -> None:
        self._drop_fbos()
        for obj, _ in self._objects.values():
            obj.release()
        self._objects.clear()
        self._size = None


def _groups(count: int) -> tuple[int, int]:
    groups = max(1, math.ceil(int(count) / 256))
    gx = min(groups, 65535)
    return gx, max(1, math.ceil(groups / gx))


__all__ = ["OitMethod", "METHOD_IDS", "HUNZ_MEMORY_MIB", "HUNZ_VIEWPORT", "END", "MiB", "GLFeatureError",
           "GPUMemoryError", "UsageError"]
