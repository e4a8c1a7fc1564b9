"""Shadows of the lights after light 0 (``RenderSettings.shadow_lights`` > 1): one map per
shadow-casting light, made by the same passes as light 0's on a frame that looks from that light.

- every method: a shadow map (R32F linear light depth, read with PCF); the hair casts into it
  unless the method is "deep_opacity";
- "deep_opacity": also a deep opacity map (Yuksel and Keyser) per light.

The maps go to ``frame.targets["extra_shadow_maps"]`` / ``["extra_doms"]`` (lists, light 1
first); ``lighting.glsl``'s ``light_visibility(i, P)`` reads them (``bind_extra_shadows``).
"""
from __future__ import annotations

from dataclasses import replace

from .base import Frame, Pass
from .deep_opacity import DeepOpacityPass
from .shadow_map import ShadowMapPass


class _LightShadowMap(ShadowMapPass):
    name = "extra_shadow_map"

    def hair_casts(self) -> bool:
        return self.renderer.settings.shadows != "deep_opacity"


class ExtraShadowsPass(Pass):
    name = "extra_shadows"
    reads = ("strands", "head")
    writes = ("extra_shadow_maps", "extra_doms")
    light_space = True

    def __init__(self, renderer):
        super().__init__(renderer)
        self._maps: list[ShadowMapPass] = []
        self._doms: list[DeepOpacityPass] = []

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.settings.shadows != "none" and bool(frame.shadow_views)

    def run(self, frame: Frame) -> None:
        r = self.renderer
        maps, doms = [], []
        for k, (view, depth_range) in enumerate(frame.shadow_views):
            while len(self._maps) <= k:
                self._maps.append(_LightShadowMap(r))
            sub = replace(frame, light_view=view, hair_depth_range=depth_range, targets={}, shadow_views=[])
            self._maps[k].run(sub)
            maps.append(sub.targets["shadow_map"])
            if r.settings.shadows == "deep_opacity" and r.strands is not None:
                while len(self._doms) <= k:
                    self._doms.append(DeepOpacityPass(r))
                self._doms[k].run(sub)
                doms.append(sub.targets["dom"])
        frame.targets["extra_shadow_maps"] = maps
        frame.targets["extra_doms"] = doms
        r.hdr_fbo().use()

    def release(self) -> None:
        for p in self._maps + self._doms:
            p.release()
        self._maps, self._doms = [], []
