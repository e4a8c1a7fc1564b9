"""Ground-truth maps of a frame for data sets: per pixel the nearest hair segment, its strand and
guide, its depth, its screen-space direction angle with a confidence, and the hair's alpha.

    r = Renderer(RenderSettings(size=(64, 64), rasterizer="compute"))
    aux = AuxMaps(r)                 # before rendering: runs inside every later frame
    r.render(camera, lights)
    m = aux.read()                   # top row first, like Renderer.read_image
    m["segment"]   # (H, W) int64: the nearest segment's first point index into the expanded
                   #   strands (ExpandPass.read: strand = segment // points), -1 where no hair
    m["strand"], m["guide"]          # (H, W) uint32, 0xFFFFFFFF where no hair
    m["depth"]     # (H, W) float32: metres along the view direction at the pixel centre, 0: none
    m["angle"]     # (H, W) float32 in [0, pi): the strand's image direction from +x (right),
                   #   counter-clockwise as seen (toward the top of the image)
    m["confidence"]  # (H, W) float32 in [0, 1]: coherence of the pixel's samples' directions
    m["alpha"]     # (H, W) float32: the hair's coverage (mean over the pixel's samples)
                   # (read-only views of one read-back, but "segment")

It needs the compute rasteriser (settings.rasterizer="compute" and pipeline="compute"): its
kernel (aux_maps.comp, beside this file) reads the rasteriser's per-sample visibility between
its raster and shade steps (HairComputePass.after_raster). Guide ids follow single-guide
interpolation (rendered strand r belongs to guide r // strands_per_guide).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..gpu.glsl import compute_shader
from .bindings import B_AUX_OUT, B_EXPANDED
from .passes.base import set_uniform, set_view

HERE = Path(__file__).resolve().parent
PLANES = 7   # aux_maps.comp's AUX_PLANES
NONE = np.uint32(0xFFFFFFFF)


class AuxMaps:
    """Attach to a Renderer; every frame it renders fills the maps that ``read`` returns."""

    def __init__(self, renderer):
        s = renderer.settings
        if not renderer.compute_raster:
            raise UsageError("ground-truth maps need the compute rasteriser (rasterizer='compute', "
                             "pipeline='compute', oit='none')")
        if s.supersample != 1 or s.interpolation_mode != "single":
            raise UsageError("ground-truth maps need supersample=1 and interpolation_mode='single'")
        self.renderer = renderer
        self.ctx = renderer.ctx
        self._out = None
        self._size = None
        self._points = 0
        self._fresh = False
        self.pass_ = renderer.get_pass("hair_compute")
        self.pass_.after_raster.append(self._run)

    def _buffers(self, w: int, h: int) -> None:
        if self._size == (w, h):
            return
        self._release_buffers()
        self._out = self.ctx.buffer(reserve=w * h * 4 * PLANES)
        self._size = (w, h)

    def _run(self, frame) -> None:
        r, ctx = self.renderer, self.ctx
        hp = self.pass_
        expand = r.get_pass("expand")
        w, h = r.settings.render_size
        self._buffers(w, h)
        cs = compute_shader(ctx, HERE / "aux_maps.comp", {"VIS64": int(hp.vis64)}, include_dirs=[HERE / "passes"])
        grid = r.raster_grid
        set_view(cs, frame.view)
        set_uniform(cs, "u_raster_size", (w * grid, h * grid))
        set_uniform(cs, "u_grid", int(grid))
        set_uniform(cs, "u_lines", int(r.settings.geometry == "lines"))
        set_uniform(cs, "u_points_per_strand", int(expand.points))
        set_uniform(cs, "u_strands_per_guide", int(r.settings.strands_per_guide))
        expand.buffer.bind_to_storage_buffer(B_EXPANDED)
        self._out.bind_to_storage_buffer(B_AUX_OUT)
        with r.profiler.section("aux_maps"):
            cs.run(math.ceil(w / 8), math.ceil(h / 8))
            ctx.memory_barrier()
        self._points = int(expand.points)
        self._fresh = True

    def read(self) -> dict:
        """The last frame's maps (see the module's docstring), rows top first."""
        self._check_fresh()
        return self.unpack(self._out.read(), self._size)

    def _check_fresh(self) -> None:
        if not self._fresh:
            raise UsageError("no ground-truth maps yet: render a frame with hair first")

    def nbytes(self, segment: bool = True) -> int:
        """The bytes of the last frame's maps (what copy_to writes)."""
        self._check_fresh()
        return self._out.size // PLANES * (PLANES - (not segment))

    def copy_to(self, buffer, segment: bool = True) -> tuple[int, int]:
        """Queue a GPU copy of the last frame's maps (without "segment": the others) into
        ``buffer`` (at least ``nbytes``; for an asynchronous read-back, render/readback.py);
        unpack(its bytes, the returned size, segment) gives the maps."""
        self._check_fresh()
        skip = 0 if segment else self._out.size // PLANES
        self.ctx.copy_buffer(buffer, self._out, size=self._out.size - skip, read_offset=skip)
        return self._size

    @staticmethod
    def unpack(data, size: tuple[int, int], segment: bool = True) -> dict:
        """The maps' dict (the module's docstring) from the bytes of the aux buffer (from its
        second plane on without ``segment``)."""
        w, h = size
        n = PLANES - (not segment)
        planes = np.frombuffer(data, np.uint32, count=n * w * h).reshape(n, h, w)   # read-only views
        floats = planes.view(np.float32)
        first = PLANES - n
        maps = {"segment": planes[0].astype(np.int64) - 1} if segment else {}
        for k, name in enumerate(("strand", "guide", "depth", "angle", "confidence", "alpha"), start=1):
            maps[name] = (planes if k < 3 else floats)[k - first]
        return maps

    def _release_buffers(self) -> None:
        if self._out is not None:
            self._out.release()
        self._out = None
        self._size = None

    def release(self) -> None:
        if self._run in self.pass_.after_raster:
            self.pass_.after_raster.remove(self._run)
        self._release_buffers()


def read_hdr(renderer) -> np.ndarray:
    """(H, W, 3) float16 linear radiance of the last frame before tone mapping, top row first."""
    color, _ = renderer.hdr_textures()
    w, h = color.size
    data = np.frombuffer(color.read(), np.float16).reshape(h, w, 4)[::-1, :, :3]
    return np.ascontiguousarray(data)
