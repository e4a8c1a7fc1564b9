"""Light 0's shadow map: nearest linear light depth (m) in an R32F texture, read with PCF.

With ``shadows="shadow_map"`` the head and the hair cast; with ``"deep_opacity"`` only the
head does (the hair's own shadow comes from the opacity layers).
"""
from __future__ import annotations

from ...gpu.glsl import program
from .base import HERE, PASS_SHADOW_DEPTH, Frame, Pass, draw_hair, hair_program, set_view

FAR = 1.0e9


class ShadowMapPass(Pass):
    name = "shadow_map"
    reads = ("strands", "head")
    writes = ("shadow_map",)

    def __init__(self, renderer):
        super().__init__(renderer)
        n = int(renderer.settings.shadow_map_size)
        self.texture = self.ctx.texture((n, n), 1, dtype="f4")
        self.texture.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        self.depth = self.ctx.depth_renderbuffer((n, n))
        self.fbo = self.ctx.framebuffer([self.texture], self.depth)

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.settings.shadows != "none" and frame.light_view is not None

    def run(self, frame: Frame) -> None:
        ctx, r = self.ctx, self.renderer
        self.fbo.use()
        self.fbo.clear(FAR, FAR, FAR, FAR, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
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
        import numpy as np

        n = self.texture.size
        return np.frombuffer(self.texture.read(), np.float32).reshape(n[1], n[0]).copy()

    def release(self) -> None:
        for o in (self.fbo, self.texture, self.depth):
            o.release()
