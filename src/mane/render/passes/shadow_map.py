"""Light 0's shadow map: nearest linear light depth (m) in an R32F texture, read with PCF.

With ``shadows="shadow_map"`` the head and the hair cast; with ``"deep_opacity"`` only the
head does (the hair's own shadow comes from the opacity layers).
"""
from __future__ import annotations

from ...gpu.glsl import program
from .base import (HERE, PASS_SHADOW_DEPTH, Frame, Pass, begin_light_depth, draw_hair, hair_program,
                   light_depth_target, read_f32, set_view)


class ShadowMapPass(Pass):
    name = "shadow_map"
    reads = ("strands", "head")
    writes = ("shadow_map",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.texture, self.depth, self.fbo = light_depth_target(self.ctx, int(renderer.settings.shadow_map_size))

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.settings.shadows != "none" and frame.light_view is not None

    def run(self, frame: Frame) -> None:
        ctx, r = self.ctx, self.renderer
        begin_light_depth(ctx, self.fbo)
        ctx.disable(ctx.CULL_FACE)
        if r.head is not None and r.settings.draw_head:
            prog = program(ctx, vertex=HERE / "head.vert", fragment=HERE / "head.frag",
                           defines={"PASS": 1, "SHADOWS": 0})
            set_view(prog, frame.light_view)
            r.draw_head(prog)
        if r.strands is not None and self.hair_casts():
            draw_hair(r, hair_program(r, PASS_SHADOW_DEPTH), frame.light_view)
        frame.targets["shadow_map"] = self.texture

    def hair_casts(self) -> bool:
        """Whether the hair is drawn into this map (else another map carries its shadow)."""
        return self.renderer.settings.shadows == "shadow_map"

    def read(self):
        return read_f32(self.texture)

    def release(self) -> None:
        for o in (self.fbo, self.texture, self.depth):
            o.release()
