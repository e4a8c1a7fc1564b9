"""The head mesh: Lambert skin, the scalp tinted toward the hair, shadowed by hair and head."""
from __future__ import annotations

import numpy as np

from ...gpu.glsl import program
from .base import shader_path, Frame, Pass, bind_lighting, set_uniform, set_view, shadow_defines


class HeadPass(Pass):
    name = "head"
    reads = ("head", "shadow_map", "dom")
    writes = ("hdr",)

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.head is not None and self.renderer.settings.draw_head

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        s = r.settings
        prog = program(ctx, vertex=shader_path("head.vert"), fragment=shader_path("head.frag"),
                       defines={"PASS": 0, **shadow_defines(s, pcf=s.head_pcf)})   # the skin's own filter
        r.hdr_fbo().use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        set_view(prog, frame.view)
        bind_lighting(r, prog, frame)
        set_uniform(prog, "u_skin", tuple(s.skin_color))
        hair = r.hair_color()
        set_uniform(prog, "u_scalp_color", tuple(0.8 * c + 0.2 * k for c, k in zip(hair, s.skin_color)))
        # a closed head wound outward shows only its front faces: culling the back ones halves
        # the fragments on a CPU rasteriser (llvmpipe, the software preset: 41 -> 26 ms a frame),
        # the same picture; not under a mirroring transform, nor for an open or flipped mesh
        cull = r.head_closed and float(np.linalg.det(r.head_transform[:3, :3])) > 0.0
        if cull:
            ctx.cull_face = "back"
            ctx.front_face = "ccw"
            ctx.enable(ctx.CULL_FACE)
        try:
            r.draw_head(prog)
        finally:
            if cull:
                ctx.disable(ctx.CULL_FACE)
