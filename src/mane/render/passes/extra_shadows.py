"""Shadows of the lights after light 0 (``RenderSettings.shadow_lights`` > 1): one map per
shadow-casting light, made by the same passes as light 0's on a frame that looks from that light.

Their maps have ``extra_shadow_map_size`` texels a side (``extra_map_size``), light 0's
``shadow_map_size``.

- every method: a shadow map (R32F linear light depth, read with PCF); the hair casts into it
  unless the method is "deep_opacity";
- "deep_opacity": also a deep opacity map (Yuksel and Keyser) per light.

The maps go to ``frame.targets["extra_shadow_maps"]`` / ``["extra_doms"]`` (lists, light 1
first); ``lighting.glsl``'s ``light_visibility(i, P)`` reads them (``bind_extra_shadows``).
"""
from __future__ import annotations

import math
from dataclasses import replace

from ..coverage_lod import mean_width
from .base import Frame, Pass
from .deep_opacity import DeepOpacityPass
from .shadow_map import ShadowMapPass


def extra_casters(settings, lights) -> list:
    """The lights after the first that cast shadows (settings.shadow_lights); one of them has
    its maps drawn again each frame while the hair moves, in turn (frame.index % their number)."""
    return list(lights[1:int(settings.shadow_lights)]) if lights and settings.shadows != "none" else []


def extra_map_size(settings) -> int:
    """The extra lights' maps' texels a side: extra_shadow_map_size, at most shadow_map_size."""
    return min(int(settings.extra_shadow_map_size), int(settings.shadow_map_size))


class _LightShadowMap(ShadowMapPass):
    name = "extra_shadow_map"

    def hair_casts(self) -> bool:
        return self.renderer.settings.shadows != "deep_opacity"

    def map_size(self) -> int:
        return extra_map_size(self.renderer.settings)


def matched_opacity(settings, texel: float, main_texel: float) -> float:
    """The strand opacity of a deep opacity map whose texels are ``texel`` wide that darkens as
    light 0's map, of texels ``main_texel``, does. A strand covering a part c of a texel passes
    1 - c (1 - t) of the light there (t = exp(-shadow_density * strand_opacity), one fibre's), while
    the map's exp(-shadow_density * O) with O = strand_opacity * c passes t^c: the coarser the
    texels (the smaller c), the darker the map than the strands it holds (Jensen's inequality:
    the exponential of a texel's mean opacity, not the mean of its fibres' transmittances). The
    optical depth per unit of coverage that passes the strands' light is
    sigma(c) = -ln(1 - c (1 - t)) / c (-ln t at c = 1); the coarse map's opacity is scaled by
    sigma(c) / sigma(c0), c = the mean strand width over the texel (at most 1)."""
    so, density = float(settings.strand_opacity), float(settings.shadow_density)
    if so <= 0.0 or density <= 0.0 or texel <= 0.0 or main_texel <= 0.0:
        return so
    absorbed = -math.expm1(-density * so)      # 1 - t

    def sigma(c: float) -> float:
        return -math.log1p(-c * absorbed) / c

    w = mean_width(settings)
    return so * sigma(min(1.0, w / texel)) / sigma(min(1.0, w / main_texel))


class _LightDeepOpacity(DeepOpacityPass):
    def map_size(self) -> int:
        return extra_map_size(self.renderer.settings)

    def z0_every_strand(self) -> bool:
        """z0 from the thinned strands too: a fill or rim light's nearest strand need not be found
        among every strand (the H200's 100k close-up: this light's map 0.12 -> 0.08 ms)."""
        return False

    def strand_opacity(self, view) -> float:
        """As light 0's map in a frame darkens (``matched_opacity``; the map strand_opacity was
        fitted on, not a still picture's finer one): this light's view at that map's size has
        texels shadow_map_size / extra_map_size times finer."""
        r = self.renderer
        texel = view.size_at(r.scene_center())
        return matched_opacity(r.settings, texel, texel * self.map_size() / int(r.frame_settings().shadow_map_size))


class ExtraShadowsPass(Pass):
    name = "extra_shadows"
    reads = ("strands", "head")
    writes = ("extra_shadow_maps", "extra_doms")
    light_space = True

    def __init__(self, renderer):
        super().__init__(renderer)
        self._maps: list[ShadowMapPass] = []
        self._doms: list[DeepOpacityPass] = []
        self._drawn: dict = {}   # light k -> (what its maps were drawn for, their targets)

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.settings.shadows != "none" and bool(frame.shadow_views)

    def run(self, frame: Frame) -> None:
        """Each light's maps. Frame after frame (the hair moving: a simulation) one light's are
        drawn again in turn, the others' kept from the frames before, at most as many frames
        old as there are such lights: a fill's or rim's shadow a frame late is not seen, and a
        light's maps cost the H200's 100k close-up 0.08-0.09 ms and the CPU three dispatches.
        A light whose view, depth range or settings changed, new strands, a still picture's
        frames and a first frame draw at once."""
        r = self.renderer
        maps, doms = [], []
        views = frame.shadow_views
        turn = frame.index % len(views)
        dom = r.settings.shadows == "deep_opacity" and r.strands is not None
        for k, (view, depth_range) in enumerate(views):
            what = (view, depth_range, r.settings, id(r.strands), id(r.head), dom)
            kept = self._drawn.get(k)
            if kept is not None and k != turn and not frame.still and _same(kept[0], what):
                maps.append(kept[1])
                if dom:
                    doms.append(kept[2])
                continue
            while len(self._maps) <= k:
                self._maps.append(_own_programs(_LightShadowMap(r), len(self._maps)))
            sub = replace(frame, light_view=view, hair_depth_range=depth_range, targets={}, shadow_views=[])
            self._maps[k].run(sub)
            maps.append(sub.targets["shadow_map"])
            if dom:
                while len(self._doms) <= k:
                    self._doms.append(_own_programs(_LightDeepOpacity(r), len(self._doms)))
                self._doms[k].run(sub)
                doms.append(sub.targets["dom"])
            self._drawn[k] = (what, maps[-1], doms[-1] if dom else None)
        frame.targets["extra_shadow_maps"] = maps
        frame.targets["extra_doms"] = doms
        r.hdr_fbo().use()

    def release(self) -> None:
        for p in self._maps + self._doms:
            p.release()
        self._maps, self._doms, self._drawn = [], [], {}


def _own_programs(p, k: int):
    """``p`` with programs of its own: light 0's passes and each other light's set their views'
    uniforms (and the map sizes) on programs nobody else writes, so a frame writes none of them
    again while the views stay (shared, each frame wrote 26 uniforms over another light's:
    the CPU's issue with every light casting)."""
    p.instance = ("extra light", k)
    return p


def _same(a: tuple, b: tuple) -> bool:
    """(view, depth range, settings, strands id, head id, with deep opacity) alike: the objects the
    same, the range equal."""
    return a[0] is b[0] and a[1] == b[1] and a[2] is b[2] and a[3:] == b[3:]
