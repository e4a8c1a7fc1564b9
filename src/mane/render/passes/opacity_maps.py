"""Opacity shadow maps (Kim and Neumann 2001; Nguyen and Donnelly 2005; Hunz 2016 §4).

``osm_slices`` (16..32) uniform slices perpendicular to light 0 between the hair's nearest and
farthest light depth (``frame.hair_depth_range``), 4 slices per RGBA32F render target, all
targets written in one draw through multiple render targets. Depth test off, additive
blending: each hair fragment adds ``strand_opacity`` times its coverage to the one channel of
its own slice (``osm.frag``). The look-up (``shadow_osm.glsl``) takes the prefix sum of the
slices in front of the shaded depth, linear inside its slice: T = exp(-shadow_density * O).
"""
from __future__ import annotations

import numpy as np

from .base import HERE, PASS_SHADOW_DEPTH, Frame, draw_hair, hair_program, set_uniform
from .light_depth import LightDepthPass

MAX_TARGETS = 8


class OpacityMapsPass(LightDepthPass):
    """No light-depth map of its own: the slices' render targets (``maps``)."""

    name = "opacity_maps"
    method = "opacity_maps"
    reads = ("strands",)
    writes = ("osm",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.maps: list = []
        self.fbo = None
        self.range = (0.0, 1.0)

    @property
    def targets(self) -> int:
        return int(self.renderer.settings.osm_slices) // 4

    def _allocate(self) -> None:
        ctx = self.ctx
        n = int(self.renderer.settings.shadow_map_size)
        limit = int(ctx.info.get("GL_MAX_DRAW_BUFFERS", 8) or 8)
        if self.targets > min(limit, MAX_TARGETS):
            from ...errors import UsageError

            raise UsageError(f"{self.renderer.settings.osm_slices} opacity slices need {self.targets} render "
                             f"targets; this OpenGL draws to at most {limit}")
        from ...gpu.buffers import check_texture

        check_texture(ctx, (n, n), 4, 4, f"{self.targets} opacity shadow maps of {n}x{n} RGBA32F",
                      samples=self.targets, reduce="Use a smaller shadow_map_size or fewer osm_slices")
        self.maps = []
        for _ in range(self.targets):
            t = ctx.texture((n, n), 4, dtype="f4")
            t.filter = (ctx.NEAREST, ctx.NEAREST)
            self.maps.append(t)
        self.fbo = ctx.framebuffer(self.maps)

    def run(self, frame: Frame) -> None:
        if not self.maps:
            self._allocate()
        ctx, r = self.ctx, self.renderer
        lo, hi = frame.hair_depth_range
        hi = max(hi, lo + 1e-4)
        self.range = (float(lo), float(hi))
        prog = hair_program(r, PASS_SHADOW_DEPTH, fragment_file=HERE / "osm.frag",
                            extra_defines={"OSM_TARGETS": self.targets})
        set_uniform(prog, "u_osm_range", self.range)
        set_uniform(prog, "u_strand_opacity", float(r.settings.strand_opacity))
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.ONE, ctx.ONE)
        ctx.blend_equation = ctx.FUNC_ADD
        draw_hair(r, prog, frame.light_view)
        ctx.disable(ctx.BLEND)
        ctx.enable(ctx.DEPTH_TEST)
        frame.targets["osm"] = list(self.maps)
        frame.targets["osm_range"] = self.range

    def read(self) -> np.ndarray:
        """(n, n, slices) float32: each slice's own opacity (not cumulative), nearest slice first."""
        out = []
        for t in self.maps:
            w, h = t.size
            out.append(np.frombuffer(t.read(), np.float32).reshape(h, w, 4))
        return np.concatenate(out, axis=2).copy()

    def owned(self) -> tuple:
        return tuple(self.maps)

    def release(self) -> None:
        super().release()   # the slices' framebuffer is self.fbo (absent when an allocation failed half-way)
        self.maps = []
