"""The hair: tessellated, multiplied and expanded strands shaded with the hair BSDF.

Blending is premultiplied (ONE, ONE_MINUS_SRC_ALPHA) with the depth test and writes on, so
sub-pixel strands (coverage alpha < 1) fade into what lies behind them; with MSAA the
coverage goes to the sample mask instead (alpha to coverage), which needs no order.
"""
from __future__ import annotations

from .base import PASS_SHADE, Frame, Pass, bind_lighting, draw_hair, hair_program, set_uniform


class HairPass(Pass):
    name = "hair"
    reads = ("strands", "shadow_map", "dom")
    writes = ("hdr",)

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.strands is not None

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        prog = hair_program(r, PASS_SHADE)
        r.shading.bind(prog, ctx, r.settings)
        bind_lighting(r, prog, frame)
        r.hdr_fbo().use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE)
        msaa = r.samples > 1
        if msaa:
            ctx.disable(ctx.BLEND)
            ctx.enable_direct(0x809E)  # GL_SAMPLE_ALPHA_TO_COVERAGE
            ctx.enable_direct(0x809F)  # GL_SAMPLE_ALPHA_TO_ONE: covered samples are opaque
        else:
            ctx.enable(ctx.BLEND)
            ctx.blend_func = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
        set_uniform(prog, "u_premultiply", int(not msaa))
        draw_hair(r, prog, frame.view)
        if msaa:
            ctx.disable_direct(0x809E)
            ctx.disable_direct(0x809F)
        ctx.disable(ctx.BLEND)
