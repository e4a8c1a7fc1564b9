"""Deep opacity maps (Yuksel and Keyser 2008) for the hair's self-shadowing, from light 0.

1. z0: the hair's nearest linear light depth (m) per texel (depth test on).
2. opacity: depth test off, additive blending; each hair fragment adds ``strand_opacity``
   (times its coverage) to its own layer and every layer behind it; the layers end at
   z0 + d_k, d_k = ``dom_layers`` fractions of the hair's depth extent (5%, 15%, the rest).
3. z0 is copied into the alpha channel, so that shading reads one RGBA texel:
   (O1, O2, O3, z0); T(z) = exp(-density * O(z)), O piecewise linear between the layer ends.
"""
from __future__ import annotations

import numpy as np

from ...gpu.glsl import program
from .base import (HERE, PASS_DOM_DEPTH, PASS_DOM_OPACITY, Frame, Pass, begin_light_depth, draw_hair,
                   hair_program, light_depth_target, read_f32, set_uniform)


class DeepOpacityPass(Pass):
    name = "deep_opacity"
    reads = ("strands",)
    writes = ("dom",)

    def __init__(self, renderer):
        super().__init__(renderer)
        ctx = self.ctx
        n = int(renderer.settings.shadow_map_size)
        self.z0, self.depth, self.z0_fbo = light_depth_target(ctx, n)
        self.opacity = ctx.texture((n, n), 4, dtype="f4")
        self.opacity.filter = (ctx.NEAREST, ctx.NEAREST)
        self.opacity_fbo = ctx.framebuffer([self.opacity])

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.settings.shadows == "deep_opacity" and frame.light_view is not None and r.strands is not None

    def run(self, frame: Frame) -> None:
        ctx, r = self.ctx, self.renderer
        # 1. z0
        begin_light_depth(ctx, self.z0_fbo)
        draw_hair(r, hair_program(r, PASS_DOM_DEPTH), frame.light_view)
        # 2. opacity layers
        lo, hi = frame.hair_depth_range
        ext = max(hi - lo, 1e-4)
        prog = hair_program(r, PASS_DOM_OPACITY)
        self.z0.use(3)
        set_uniform(prog, "u_dom_depth", 3)
        set_uniform(prog, "u_dom_layers_abs", tuple(float(f) * ext for f in r.settings.dom_layers))
        set_uniform(prog, "u_strand_opacity", float(r.settings.strand_opacity))
        self.opacity_fbo.color_mask = (True, True, True, True)
        self.opacity_fbo.use()
        self.opacity_fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.ONE, ctx.ONE)
        ctx.blend_equation = ctx.FUNC_ADD
        draw_hair(r, prog, frame.light_view)
        ctx.disable(ctx.BLEND)
        # 3. z0 into alpha
        pack = program(ctx, vertex=HERE / "fullscreen.vert", fragment=HERE / "dom_pack.frag")
        set_uniform(pack, "u_dom_depth", 3)
        self.opacity_fbo.color_mask = (False, False, False, True)
        self.opacity_fbo.use()   # moderngl applies a framebuffer's colour mask when it is bound
        r.empty_vao(pack).render(ctx.TRIANGLES, vertices=3)
        self.opacity_fbo.color_mask = (True, True, True, True)
        self.opacity_fbo.use()
        ctx.enable(ctx.DEPTH_TEST)
        frame.targets["dom"] = self.opacity

    def read(self) -> np.ndarray:
        """(n, n, 4) float32: O1, O2, O3, z0."""
        return read_f32(self.opacity)

    def release(self) -> None:
        for o in (self.z0_fbo, self.z0, self.depth, self.opacity_fbo, self.opacity):
            o.release()
