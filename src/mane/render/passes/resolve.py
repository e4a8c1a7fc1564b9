"""HDR -> display: MSAA resolve (a blit), optional 2x supersample down-sample with Chen's
5-tap filter, exposure, tone mapping (ACES or Reinhard), background and sRGB encoding."""
from __future__ import annotations

import functools

import numpy as np

from ...gpu.glsl import ProgramMemo, program
from ..bindings import TEX_HDR
from .base import shader_path, TONE_IDS, Frame, Pass, set_uniforms


def srgb_to_linear(c):
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


@functools.lru_cache(maxsize=16)
def _background(srgb: tuple) -> tuple:
    """The background's linear RGB uniform (made once per colour)."""
    return tuple(float(x) for x in srgb_to_linear(srgb))


class ResolvePass(Pass):
    name = "resolve"
    reads = ("hdr",)
    writes = ("output",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self._memo = None   # (settings, uniforms)

    def _uniforms(self, s) -> dict:
        """The resolve's uniforms, made once per settings object."""
        if self._memo is None or self._memo[0] is not s:
            try:
                background = _background(tuple(s.background))
            except TypeError:
                background = tuple(float(x) for x in srgb_to_linear(s.background))
            self._memo = (s, {"u_hdr": TEX_HDR, "u_background": background, "u_exposure": float(s.exposure)})
        return self._memo[1]

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        s = r.settings
        hdr = r.resolved_hdr()    # blits the multisampled target when there is one
        hdr.filter = (ctx.LINEAR, ctx.LINEAR)
        prog = self._programs.get("resolve", (s,), lambda: program(
            ctx, vertex=shader_path("fullscreen.vert"), fragment=shader_path("resolve.frag"),
            defines={"SUPERSAMPLE": int(s.supersample), "TONE_MAP": TONE_IDS[s.tone_mapping]}))
        hdr.use(TEX_HDR)
        set_uniforms(prog, self._uniforms(s))
        out = r.output_fbo()
        out.use()
        ctx.disable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        r.empty_vao(prog).render(ctx.TRIANGLES, vertices=3)
        frame.targets["output"] = out
