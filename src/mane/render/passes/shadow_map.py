"""Light 0's shadow map: nearest linear light depth (m) in an R32F texture, read with PCF.

With ``shadows="shadow_map"`` the head and the hair cast; with ``"deep_opacity"`` only the
head does (the hair's own shadow comes from the opacity layers). With the compute rasteriser
the hair's depths come from a compute scan conversion (deep_opacity.scan_light_depths, the
deep opacity maps' z0) merged into the head's map (shadow_merge.comp).
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu.glsl import ProgramMemo, compute_shader, program
from ..bindings import B_DOM_Z0, IMG_SHADOW
from .base import shader_path, RENDER_DIR, Frame, set_uniform, set_view
from .deep_opacity import scan_light_depths
from .light_depth import LightDepthPass


class ShadowMapPass(LightDepthPass):
    name = "shadow_map"
    reads = ("strands", "head")
    writes = ("shadow_map",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.depth_target()   # made with the renderer: every method but "none" reads it
        self._z0 = None   # compute path: the hair's depth bits per texel
        self._programs = ProgramMemo()
        self._kept = None   # what a map of the head alone was drawn from (its head, transform, view, texture)

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.settings.shadows != "none" and frame.light_view is not None

    def run(self, frame: Frame) -> None:
        ctx, r = self.ctx, self.renderer
        kept = self._head_alone(frame)
        if kept is not None and self._kept is not None and kept[0] is self._kept[0] and kept[1:] == self._kept[1:]:
            frame.targets["shadow_map"] = self.texture   # the head and the light have not moved
            return
        self._kept = kept
        self.begin_depth()
        if r.head is not None and r.settings.draw_head:
            prog = self._programs.get("head", (), lambda: program(
                ctx, vertex=shader_path("head.vert"), fragment=shader_path("head.frag"), defines={"PASS": 1, "SHADOWS": 0},
                instance=self.instance))
            set_view(prog, frame.light_view)
            r.draw_head(prog, cull_back=True)   # the same map from half the fragments
        if r.strands is not None and self.hair_casts():
            if r.compute_raster:
                self._hair_by_compute(frame)
            else:
                self.draw_hair_depth(frame)
        frame.targets["shadow_map"] = self.texture

    def _head_alone(self, frame: Frame):
        """What the map holds when the hair does not cast into it (every method but "shadow_map"):
        the head's buffers (new at every set_head), its transform and the light's view (whose
        texel size follows the map's); None when the hair casts. A map of the head alone is drawn
        again only when one of them changes (or after release): the H200's few raster units take
        0.07 ms (512^2) to 0.19 ms (1024^2) for it."""
        r = self.renderer
        if r.strands is not None and self.hair_casts():
            return None
        head = r.head is not None and bool(r.settings.draw_head)
        return (r.head_buffers() if head else None, r.head_model() if head else None,
                tuple(frame.light_view.uniforms().items()))

    def _hair_by_compute(self, frame: Frame) -> None:
        ctx, r = self.ctx, self.renderer
        n = self.map_size()
        if self._z0 is None:
            self._z0 = ctx.buffer(np.full(n * n, 0xFFFFFFFF, np.uint32).tobytes())
        self._z0.bind_to_storage_buffer(B_DOM_Z0)
        scan_light_depths(r, frame.light_view, n, 0, programs=self._programs, instance=self.instance)
        merge = self._programs.get("merge", (), lambda: compute_shader(ctx, shader_path("shadow_merge.comp"),
                                                                       include_dirs=[RENDER_DIR], instance=self.instance))
        set_uniform(merge, "u_size", n)
        self.texture.bind_to_image(IMG_SHADOW, read=True, write=True)
        merge.run(math.ceil(n / 8), math.ceil(n / 8))
        ctx.memory_barrier()

    def hair_casts(self) -> bool:
        """Whether the hair is drawn into this map (else another map carries its shadow)."""
        return self.renderer.settings.shadows == "shadow_map"

    def owned(self) -> tuple:
        return (self._z0,)

    def release(self) -> None:
        super().release()
        self._z0 = self._kept = None
