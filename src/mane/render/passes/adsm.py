"""TressFX's approximated deep shadow map (ADSM; AMD TressFX, Tomb Raider 2013; Hunz 2016 §4).

One pass: the hair's nearest linear light depth d_s (m) from light 0 in an R32F texture
(depth test on), like a shadow map of the hair alone (the head casts through ``ShadowMapPass``).
The look-up (``shadow_adsm.glsl``) assumes that a point at depth d behind the first occluder
has crossed n = 1 + (d - d_s) / spacing fibres, spacing = ``adsm_spacing`` strand widths, and
passes (1 - alpha)^n of the light with 1 - alpha = exp(-shadow_density * strand_opacity).
Only two controls, as in TressFX: the fibre opacity and the spacing.
"""
from __future__ import annotations

import numpy as np

from .base import (PASS_SHADOW_DEPTH, Frame, Pass, begin_light_depth, draw_hair, hair_program,
                   light_depth_target, read_f32)


class ADSMPass(Pass):
    name = "adsm"
    reads = ("strands",)
    writes = ("adsm",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.texture = None

    def _allocate(self) -> None:
        self.texture, self.depth, self.fbo = light_depth_target(self.ctx, int(self.renderer.settings.shadow_map_size))

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.settings.shadows == "adsm" and frame.light_view is not None and r.strands is not None

    def run(self, frame: Frame) -> None:
        if self.texture is None:
            self._allocate()
        ctx, r = self.ctx, self.renderer
        begin_light_depth(ctx, self.fbo)
        ctx.disable(ctx.CULL_FACE)
        draw_hair(r, hair_program(r, PASS_SHADOW_DEPTH), frame.light_view)
        frame.targets["adsm"] = self.texture

    def read(self) -> np.ndarray:
        """(n, n) float32 nearest hair light depth (m); 1e9 where no hair."""
        return read_f32(self.texture)

    def release(self) -> None:
        if self.texture is not None:
            for o in (self.fbo, self.texture, self.depth):
                o.release()
            self.texture = None
