"""The hair: tessellated, multiplied and expanded strands shaded with the hair BSDF.

Blending is premultiplied (ONE, ONE_MINUS_SRC_ALPHA) with the depth test and writes on, so
sub-pixel strands (coverage alpha < 1) fade into what lies behind them; with MSAA the
coverage goes to the sample mask instead (each sample covered with probability alpha, drawn per
strand and pixel: coverage_mask.glsl), which needs no order and adds up like the compute
rasteriser's coverage; then a
depth pre-pass (settings.depth_prepass) lets the shading run once per pixel and visible strand.
With settings.ms_smoothing the multiply scattered light goes to a second colour target
(passes/ms_smooth.py: MS_SPLIT) with the same coverage.
"""
from __future__ import annotations

from . import ms_smooth
from .base import HERE, PASS_SHADE, Frame, Pass, bind_lighting, draw_hair, hair_program


class HairPass(Pass):
    name = "hair"
    reads = ("strands", "shadow_map", "dom")
    writes = ("hdr",)

    def enabled(self, frame: Frame) -> bool:   # OIT: OitPass draws the hair; compute: HairComputePass
        r = self.renderer
        return r.strands is not None and r.settings.oit == "none" and not r.compute_raster

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        msaa = r.samples > 1
        prepass = msaa and bool(r.settings.depth_prepass)
        split = ms_smooth.active(r)
        prog = hair_program(r, PASS_SHADE, extra_defines={"SAMPLE_MASK": int(msaa), "MS_SPLIT": int(split)})
        r.shading.bind(prog, ctx, r.settings)
        bind_lighting(r, prog, frame)
        smoothing = r.get_pass("ms_smooth")
        target = smoothing.hair_fbo() if split else r.hdr_fbo()   # the HDR colour (and the split's) and depth
        target.use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE)
        if msaa:   # the coverage as a per-strand random sample mask (coverage_mask.glsl), opaque
            ctx.disable(ctx.BLEND)
        else:
            ctx.enable(ctx.BLEND)
            ctx.blend_func = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
        if prepass:
            # depth first (the coverage mask, a trivial fragment shader, no colour), then shade
            # once per pixel and visible strand: LEQUAL, no depth writes (the driver tests
            # depth early; layout(early_fragment_tests) measured no faster), the same mask
            # again (the same strand, pixel and alpha give the same samples)
            depth = hair_program(r, PASS_SHADE, fragment_file=HERE / "hair_depth.frag")
            fbo = r.hdr_fbo()
            fbo.color_mask = (False, False, False, False)
            fbo.use()
            draw_hair(r, depth, frame.view)
            fbo.color_mask = (True, True, True, True)
            target.depth_mask = False
            target.use()
            ctx.depth_func = "<="
        draw_hair(r, prog, frame.view)
        if prepass:
            target.depth_mask = True
            target.use()
            ctx.depth_func = "<"
        ctx.disable(ctx.BLEND)
        if split:
            smoothing.resolve()
            r.hdr_fbo().use()
