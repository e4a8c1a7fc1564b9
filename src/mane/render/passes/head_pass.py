"""The head mesh: Lambert skin, the scalp tinted toward the hair (``scalp_tint``), shadowed by hair
and head."""
from __future__ import annotations

import math

import numpy as np

from ...gpu.capabilities import get_capabilities
from ...gpu.glsl import ProgramMemo, compute_shader, program
from ...gpu.uniforms import write_uniform
from ..camera import mat_bytes
from ..screen_box import FULL
from ..bindings import B_HEAD_FACES, B_HEAD_VERTICES, IMG_HDR, TEX_HEAD_ID, TEX_SCENE_DEPTH
from .base import RENDER_DIR, shader_path, Frame, Pass, bind_lighting, set_uniforms, set_view, shadow_defines

# With a single-sample HDR target (the compute rasteriser's) on a GPU the raster units draw only
# the head's depth and nearest triangle, and head_shade.comp shades it (H200, 1080p: the 100k
# close-up's head 0.756 -> 0.220 ms); on a CPU rasteriser head.frag shades every fragment, as
# with MSAA (llvmpipe, the demo at 960x540: the head 50 ms by head.frag, 215 by compute).
# None: by the renderer; True / False: forced (tests)
SHADE_BY_COMPUTE = None


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
        self._ids = None    # (the triangle-id texture, its framebuffer with the HDR depth, that depth)
        self._inverse = None   # (view, {"u_inv_view_proj": ...})

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.head is not None and self.renderer.settings.draw_head

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        s = r.settings
        by_compute = SHADE_BY_COMPUTE
        if by_compute is None:
            by_compute = not get_capabilities(ctx).is_software
        if by_compute and r.samples == 1:
            self._run_compute(frame)
            return
        prog = self._programs.get("head", (s,), lambda: program(
            ctx, vertex=shader_path("head.vert"), fragment=shader_path("head.frag"),
            defines={"PASS": 0, **shadow_defines(ctx, s, pcf=s.head_pcf)}))   # the skin's own filter
        r.hdr_fbo().use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        set_view(prog, frame.view)
        bind_lighting(r, prog, frame)
        set_uniforms(prog, self._colors.uniforms(r))
        # the back faces of a closed head culled: on a CPU rasteriser (llvmpipe, the software
        # preset) 41 -> 26 ms a frame, the same picture
        r.draw_head(prog, cull_back=True)

    def _run_compute(self, frame: Frame) -> None:
        """The head's depth and triangle ids by the raster units, its colour by head_shade.comp."""
        r, ctx = self.renderer, self.ctx
        s = r.settings
        target = r.hdr_target()
        ids = self._ids
        if ids is None or ids[2] is not target.depth:
            self._release_ids()
            tex = ctx.texture(target.depth.size, 1, dtype="u4")
            ids = self._ids = (tex, ctx.framebuffer([tex], target.depth), target.depth)
        tex, fbo, depth = ids
        prog = self._programs.get("head_id", (), lambda: program(
            ctx, vertex=shader_path("head.vert"), fragment=shader_path("head.frag"),
            defines={"PASS": 2, "SHADOWS": 0}))
        fbo.use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        set_view(prog, frame.view)
        r.draw_head(prog, cull_back=True)
        cs = self._programs.get("head_shade", (s,), lambda: compute_shader(
            ctx, shader_path("head_shade.comp"), shadow_defines(ctx, s, pcf=s.head_pcf), include_dirs=[RENDER_DIR]))
        set_view(cs, frame.view)
        bind_lighting(r, cs, frame)
        set_uniforms(cs, self._colors.uniforms(r))
        set_uniforms(cs, self._inverse_uniforms(frame.view))
        write_uniform(cs["u_head_model"], r.head_model()[0])
        depth.use(TEX_SCENE_DEPTH)
        tex.use(TEX_HEAD_ID)
        vbo, ibo = r.head_buffers()
        vbo.bind_to_storage_buffer(B_HEAD_VERTICES)
        ibo.bind_to_storage_buffer(B_HEAD_FACES)
        target.color.bind_to_image(IMG_HDR, read=False, write=True)
        # the pixels of the head's screen box only (the renderer's, as the depth's clear): the
        # head drew none outside it; None: it is off screen
        box = r.head_screen_box(frame.view)
        if box is not None:
            x, y, w, h = (0, 0, *depth.size) if box == FULL else box
            write_uniform(cs["u_origin"], (x, y))
            cs.run(math.ceil(w / 8), math.ceil(h / 8))
            ctx.memory_barrier()
        target.fbo.use()

    def _inverse_uniforms(self, view) -> dict:
        memo = self._inverse
        if memo is None or memo[0] is not view:
            inv = np.linalg.inv(np.asarray(view.view_proj, np.float64))
            memo = self._inverse = (view, {"u_inv_view_proj": mat_bytes(inv), "u_scene_depth": TEX_SCENE_DEPTH,
                                           "u_head_id": TEX_HEAD_ID})
        return memo[1]

    def _release_ids(self) -> None:
        if self._ids is not None:
            self._ids[1].release()
            self._ids[0].release()
            self._ids = None

    def release(self) -> None:
        self._release_ids()
        super().release()
