"""HDR -> display: MSAA resolve (a blit), optional 2x supersample down-sample with Chen's
5-tap filter, exposure, tone mapping (ACES or Reinhard), background and sRGB encoding."""
from __future__ import annotations

import functools
import math

import numpy as np

from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import IMG_OUTPUT, TEX_HDR
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
        hdr = r.shown_hdr(frame.still)   # a still scene's mean (accumulate.py) or this frame's target
        hdr.filter = (ctx.LINEAR, ctx.LINEAR)
        cs = self._programs.get("resolve", (s,), lambda: compute_shader(
            ctx, shader_path("resolve.comp"),
            defines={"SUPERSAMPLE": int(s.supersample), "TONE_MAP": TONE_IDS[s.tone_mapping]}))
        hdr.use(TEX_HDR)
        set_uniforms(cs, self._uniforms(s))
        out, tex = r.output_target()
        tex.bind_to_image(IMG_OUTPUT, read=False, write=True)
        w, h = s.size
        cs.run(math.ceil(w / 8), math.ceil(h / 8))
        ctx.memory_barrier()
        out.use()   # later draws (the viewer's overlays) and reads go to the output
        frame.targets["output"] = out
