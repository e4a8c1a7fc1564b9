"""TressFX's approximated deep shadow map (ADSM; AMD TressFX, Tomb Raider 2013; Hunz 2016 §4).

One pass: the hair's nearest linear light depth d_s (m) from light 0 in an R32F texture
(depth test on), like a shadow map of the hair alone (the head casts through ``ShadowMapPass``).
The look-up (``shadow_adsm.glsl``) assumes that a point at depth d behind the first occluder
has crossed n = 1 + (d - d_s) / spacing fibres, spacing = ``adsm_spacing`` strand widths, and
passes (1 - alpha)^n of the light with 1 - alpha = exp(-shadow_density * strand_opacity).
Only two controls, as in TressFX: the fibre opacity and the spacing.
"""
from __future__ import annotations

from .base import Frame
from .light_depth import LightDepthPass


class ADSMPass(LightDepthPass):
    name = "adsm"
    method = "adsm"
    reads = ("strands",)
    writes = ("adsm",)

    def run(self, frame: Frame) -> None:
        self.begin_depth()
        self.draw_hair_depth(frame)
        frame.targets["adsm"] = self.texture
