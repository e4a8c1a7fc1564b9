"""The head mesh: Lambert skin, the scalp tinted toward the hair, shadowed by hair and head."""
from __future__ import annotations

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
        r.draw_head(prog)
