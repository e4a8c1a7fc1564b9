"""The light-depth passes' common skeleton: a map rendered from a shadow-casting light.

Light 0's shadow map, deep opacity map, ADSM, opacity shadow maps and density volume (and
the extra lights' maps, the same passes run on a frame that looks from that light) share it:

- ``enabled``: ``settings.shadows`` is the pass's ``method``, the frame has a light view and
  there are strands;
- ``map_size()``: its texels a side (``shadow_map_size``; the extra lights' maps
  ``extra_map_size``);
- ``depth_target()``: the pass's R32F linear light-depth map (``texture``, ``depth``, ``fbo``),
  made on first use at that size;
- ``begin_depth()`` binds it cleared to FAR (depth test on, blending and culling off) and
  ``draw_hair_depth(frame)`` draws the hair's nearest light depth into it;
- ``read()`` returns the map, ``release()`` frees it and what ``owned()`` lists.
"""
from __future__ import annotations

import numpy as np

from .base import (PASS_SHADOW_DEPTH, Frame, Pass, begin_light_depth, draw_hair, hair_program,
                   light_depth_target, read_f32)


class LightDepthPass(Pass):
    method = ""   # the settings.shadows value that turns the pass on
    light_space = True
    instance = None   # programs of its own (gpu.glsl.compute_shader's instance): an extra light's passes

    def __init__(self, renderer):
        super().__init__(renderer)
        self.texture = self.depth = self.fbo = None

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.settings.shadows == self.method and frame.light_view is not None and r.strands is not None

    def map_size(self) -> int:
        """The map's texels a side."""
        return int(self.renderer.settings.shadow_map_size)

    def depth_target(self):
        """The light-depth framebuffer (its texture and depth renderbuffer made on first use)."""
        if self.texture is None:
            self.texture, self.depth, self.fbo = light_depth_target(self.ctx, self.map_size())
        return self.fbo

    def begin_depth(self, cull: bool = False) -> None:
        """Bind the light-depth map cleared to FAR; face culling off unless ``cull``."""
        begin_light_depth(self.ctx, self.depth_target())
        if not cull:
            self.ctx.disable(self.ctx.CULL_FACE)

    def draw_hair_depth(self, frame: Frame) -> None:
        """The hair's nearest linear light depth into the bound map."""
        r = self.renderer
        draw_hair(r, hair_program(r, PASS_SHADOW_DEPTH, instance=self.instance), frame.light_view)

    def read(self) -> np.ndarray:
        """(n, n) float32 nearest light depth (m); FAR where nothing was drawn."""
        return read_f32(self.texture)

    def owned(self) -> tuple:
        """GPU objects of the pass besides its light-depth map (released with it)."""
        return ()

    def release(self) -> None:
        for o in (self.fbo, self.texture, self.depth, *self.owned()):
            if o is not None:
                o.release()
        self.texture = self.depth = self.fbo = None
