"""settings.ms_smoothing: the compute rasteriser's multiply scattered light smoothed across the hair.

Dual scattering (shading/dual_scattering.py) evaluates the light the volume scatters at each
visible fibre with that fibre's own tangent, so it varies from one fibre to the next as the
direct light does. In the volume a fibre gathers scattered light from every direction, and what
it sends on hardly depends on its tangent: against the path tracer, mane's multiply scattered
light smoothed over 2-4 mm of hair takes Sintel blond from 0.34 to 0.27-0.28 relative error per
pixel with its luminance and falloff unchanged, while the same smoothing of the direct light makes
it worse (docs/quality.md, "The lead this points to").

With ``ms_smoothing`` > 0 the shading pass (hair_shade.comp, MS_SPLIT) writes the multiply
scattered radiance times each pixel's hair coverage, and the coverage, to a target of its own
(``target``); this pass smooths both with a Gaussian of ``ms_smoothing`` metres (in pixels at
the hair's centre, at most ``MAX_SIGMA``), rows then columns (ms_smooth.comp), and adds the
smoothed radiance per unit of coverage, times the pixel's own coverage, to the HDR colour. The
total over a uniformly covered patch is unchanged. ``smooth_numpy`` is its twin.

The hardware rasteriser and the transparency methods keep the fibre's own term.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ...gpu.clear import clear_texture
from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import IMG_HDR, IMG_MS, IMG_MS_ROWS
from .base import Frame, Pass, set_uniforms, shader_path

MAX_SIGMA = 8.0    # pixels: a close-up's 3 mm can be tens of pixels; the taps stay at most 49 a pass
RADIUS = 3.0       # taps each side, in sigmas


def active(renderer) -> bool:
    """Whether the frame splits and smooths the multiply scattered light."""
    s = renderer.settings
    return float(s.ms_smoothing) > 0.0 and renderer.compute_raster and s.oit == "none"


def sigma_pixels(view, width_m: float, center) -> float:
    """``width_m`` in pixels of ``view`` at the world point ``center`` (at most MAX_SIGMA)."""
    px = view.pixel_size if view.ortho else view.pixel_size * float(np.linalg.norm(np.asarray(center) - view.eye))
    return float(min(width_m / max(px, 1e-12), MAX_SIGMA))


def taps(sigma: float) -> int:
    return max(1, int(math.ceil(RADIUS * sigma)))


class MsSmoothPass(Pass):
    name = "ms_smooth"
    reads = ("hdr",)
    writes = ("hdr",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self._targets = None   # (size, ms texture, rows texture)

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.strands is not None and active(r)

    def target(self):
        """The multiply scattered light's target (RGBA16F at the render size), cleared: the
        shading pass writes only the pixels with hair."""
        size = tuple(self.renderer.settings.render_size)
        if self._targets is None or self._targets[0] != size:
            from ...gpu.buffers import check_texture

            self.release()
            check_texture(self.ctx, size, 4, 2, f"the multiply scattered light's targets ({size[0]}x{size[1]})",
                          extra_bytes=size[0] * size[1] * 8, reduce="Use a smaller --size or ms_smoothing 0")
            ms = self.ctx.texture(size, 4, dtype="f2")
            rows = self.ctx.texture(size, 4, dtype="f2")
            self._targets = (size, ms, rows)
        clear_texture(self.ctx, self._targets[1], programs=self._programs)
        return self._targets[1]

    def run(self, frame: Frame) -> None:
        r = self.renderer
        if self._targets is None:
            return
        lo, hi = r.hair_bbox()
        sigma = sigma_pixels(frame.view, float(r.settings.ms_smoothing), 0.5 * (np.asarray(lo) + np.asarray(hi)))
        # the single-sample colour the shading pass wrote (with a multisampled head, the resolve of it)
        smooth(self.ctx, self._targets[1], self._targets[2], r.hdr_textures()[0], sigma, self._programs)

    def release(self) -> None:
        if self._targets is not None:
            for t in self._targets[1:]:
                t.release()
            self._targets = None


@functools.lru_cache(maxsize=16)
def _uniforms(sigma: float) -> dict:
    """smooth's uniforms, one dict per sigma (set_uniforms skips them by identity)."""
    return {"u_radius": taps(sigma), "u_sigma": sigma}


def smooth(ctx, ms, rows, hdr, sigma: float, programs: ProgramMemo | None = None) -> None:
    """ms_smooth.comp's two dispatches: ``ms`` (radiance x coverage, coverage) smoothed by a
    Gaussian of ``sigma`` pixels into ``hdr`` (rows through ``rows``)."""
    w, h = ms.size
    u = _uniforms(float(sigma))
    for direction in (0, 1):
        def build(direction=direction):
            return compute_shader(ctx, shader_path("ms_smooth.comp"), {"DIRECTION": direction})
        cs = build() if programs is None else programs.get(("ms_smooth", direction), (), build)
        set_uniforms(cs, u)
        if direction == 0:
            ms.bind_to_image(IMG_MS, read=True, write=False)
            rows.bind_to_image(IMG_MS_ROWS, read=False, write=True)
        else:
            rows.bind_to_image(IMG_MS_ROWS, read=True, write=False)
            ms.bind_to_image(IMG_MS, read=True, write=False)
            hdr.bind_to_image(IMG_HDR, read=True, write=True)
        cs.run(math.ceil(w / 8), math.ceil(h / 8))
        ctx.memory_barrier()


def smooth_numpy(ms: np.ndarray, hdr: np.ndarray, sigma: float) -> np.ndarray:
    """The twin: (H, W, 4) ``ms`` (radiance x coverage, coverage) and ``hdr`` -> ``hdr`` with the
    smoothed radiance per unit of coverage times each pixel's coverage added where it has hair
    (the same taps as ms_smooth.comp, none past the image's edge)."""
    from scipy.ndimage import correlate1d

    n = taps(sigma)
    k = np.exp(-0.5 * (np.arange(-n, n + 1) / sigma) ** 2)
    ms = np.asarray(ms, np.float64)
    s = correlate1d(correlate1d(ms, k, axis=1, mode="constant"), k, axis=0, mode="constant")
    out = np.array(hdr, np.float64)
    hair = ms[..., 3] > 0
    out[..., :3] += np.where(hair[..., None], s[..., :3] / np.maximum(s[..., 3:], 1e-6) * ms[..., 3:], 0.0)
    return out
