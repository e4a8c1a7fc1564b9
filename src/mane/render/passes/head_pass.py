"""The head mesh: Lambert skin, the scalp tinted toward the hair (``scalp_tint``), shadowed by hair
and head."""
from __future__ import annotations

from ...gpu.glsl import ProgramMemo, program
from .base import shader_path, Frame, Pass, bind_lighting, set_uniforms, set_view, shadow_defines


def scalp_albedo(skin, hair, tint: float) -> tuple:
    """The scalp's albedo: ``tint`` of the way from the skin's colour to the hair's."""
    return tuple((1.0 - tint) * k + tint * c for k, c in zip(skin, hair))


class SkinColors:
    """The skin's and the scalp's colour uniforms of a renderer (made again when the skin colour,
    the hair's or the scalp tint changes): the head pass's and the skin bounce's map."""

    def __init__(self):
        self._memo = None   # ((skin colour, hair colour, scalp tint), their uniforms)

    def uniforms(self, renderer) -> dict:
        skin, hair, tint = renderer.settings.skin_color, renderer.hair_color(), float(renderer.settings.scalp_tint)
        memo = self._memo
        if memo is None or memo[0] != (skin, hair, tint):
            u = {"u_skin": tuple(skin), "u_scalp_color": scalp_albedo(skin, hair, tint)}
            memo = self._memo = ((skin, hair, tint), u)
        return memo[1]


class HeadPass(Pass):
    name = "head"
    reads = ("head", "shadow_map", "dom")
    writes = ("hdr",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self._colors = SkinColors()

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.head is not None and self.renderer.settings.draw_head

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        s = r.settings
        prog = self._programs.get("head", (s,), lambda: program(
            ctx, vertex=shader_path("head.vert"), fragment=shader_path("head.frag"),
            defines={"PASS": 0, **shadow_defines(s, pcf=s.head_pcf)}))   # the skin's own filter
        r.hdr_fbo().use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        set_view(prog, frame.view)
        bind_lighting(r, prog, frame)
        set_uniforms(prog, self._colors.uniforms(r))
        # the back faces of a closed head culled: on a CPU rasteriser (llvmpipe, the software
        # preset) 41 -> 26 ms a frame, the same picture
        r.draw_head(prog, cull_back=True)
