"""settings.ms_smoothing: the multiply scattered light smoothed across the hair.

Dual scattering (shading/dual_scattering.py) evaluates the light the volume scatters at each
visible fibre with that fibre's own tangent, so it varies from one fibre to the next as the
direct light does. In the volume a fibre gathers scattered light from every direction, and what
it sends on hardly depends on its tangent: against the path tracer, mane's multiply scattered
light smoothed over 2-4 mm of hair takes Sintel blond from 0.34 to 0.27-0.28 relative error per
pixel with its luminance and falloff unchanged, while the same smoothing of the direct light makes
it worse (docs/quality.md, "The lead this points to").

With ``ms_smoothing`` > 0 the shading pass (hair_shade.comp or hair_main.glsl, MS_SPLIT) writes the multiply
scattered radiance times each pixel's hair coverage, and the coverage, to a target of its own
(``target``); this pass smooths both with a Gaussian of ``ms_smoothing`` metres (in pixels at
the hair's centre, at most ``MAX_SIGMA``) and adds the smoothed radiance per unit of coverage,
times the pixel's own coverage, to the HDR colour. The total over a uniformly covered patch is
unchanged. A wide Gaussian is applied on a reduced grid (``factor``: cells of 2 x 2 or 4 x 4
pixels, their sums smoothed by a narrower Gaussian, rows then columns, and interpolated back
bilinearly, ``low_sigma`` making up the cells' and the interpolation's own spread), so its cost
does not follow the close-up's size. ``smooth_numpy`` is its twin.

The hardware rasteriser draws the split into a second colour target (``hair_fbo``), with the
hair's coverage as its alpha or, with MSAA, the same sample mask, resolved as the HDR colour is.
The transparency methods keep the fibre's own term.
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from ...gpu.clear import clear_texture
from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import IMG_HDR, IMG_MS, IMG_MS_DST, IMG_MS_SRC
from . import sample_resolve
from .base import Frame, Pass, set_uniforms, shader_path

MAX_SIGMA = 8.0    # pixels: a close-up's 3 mm can be tens of pixels
RADIUS = 3.0       # taps each side, in sigmas


def active(renderer) -> bool:
    """Whether the frame splits and smooths the multiply scattered light."""
    return active_for(renderer.settings)


def active_for(settings) -> bool:
    """Whether frames with these settings smooth the multiply scattered light."""
    return float(settings.ms_smoothing) > 0.0 and settings.oit == "none"


def sigma_pixels(view, width_m: float, center) -> float:
    """``width_m`` in pixels of ``view`` at the world point ``center`` (at most MAX_SIGMA)."""
    return float(min(width_m / max(view.size_at(center), 1e-12), MAX_SIGMA))


def taps(sigma: float) -> int:
    return max(1, int(math.ceil(RADIUS * sigma)))


FACTORS = (1, 2, 4)   # the reduced grid's cells, pixels a side (factor)


def factor(sigma: float) -> int:
    """The reduced grid's cell, in pixels a side, for a Gaussian of ``sigma`` pixels: one where
    the cells' own spread would be most of it."""
    return FACTORS[0] if sigma < 1.5 else FACTORS[1] if sigma < 5.0 else FACTORS[2]


def low_sigma(sigma: float, f: int) -> float:
    """The Gaussian on the grid of ``f``-pixel cells (in cells) whose result, with the cells' box
    (variance (f^2 - 1) / 12 pixels^2) and the bilinear interpolation back ((f^2 - 1) / 6), has
    the variance of ``sigma`` pixels."""
    return math.sqrt(max(sigma * sigma - (f * f - 1) / 4.0, 1e-6)) / f


def low_size(size, f: int) -> tuple[int, int]:
    return (-(-int(size[0]) // f), -(-int(size[1]) // f))


class _HairTargets(NamedTuple):
    """The hardware rasteriser's split: drawn through ``fbo`` (the HDR colour, then the multiply
    scattered light's ``ms`` texture or, multisampled, ``samples``), the samples resolved from
    ``samples_fbo`` into ``ms_fbo``."""
    hdr: object
    ms: object
    fbo: object
    samples: object = None
    samples_fbo: object = None
    ms_fbo: object = None


class MsSmoothPass(Pass):
    name = "ms_smooth"
    reads = ("hdr",)
    writes = ("hdr",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self._targets = None   # (size, ms texture)
        self._grids = None     # (size, the reduced grid's two textures)
        self._hair = None      # the hardware rasteriser's targets (_HairTargets)
        self._plan = None      # ((sigma, hdr, grid), plan's steps)
        self._sigma_memo = None
        self._written = False  # the target holds a frame's light that no smoothing has cleared

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.strands is not None and active(r)

    def target(self):
        """The multiply scattered light's target (RGBA16F at the render size), clear: the
        shading pass writes only the pixels with hair, and the smoothing clears those it read
        (cleared here only where a frame wrote it and did not smooth it)."""
        size = tuple(self.renderer.settings.render_size)
        if self._targets is None or self._targets[0] != size:
            from ...gpu.buffers import check_texture

            self.release()
            check_texture(self.ctx, size, 4, 2, f"the multiply scattered light's target ({size[0]}x{size[1]})",
                          samples=1 if self.renderer.compute_raster else self.renderer.samples,
                          extra_bytes=size[0] * size[1] * 40, reduce="Use a smaller --size or ms_smoothing 0")
            self._targets = (size, self.ctx.texture(size, 4, dtype="f2"))
            self._written = True   # a new texture's contents are undefined
        if self._written:
            clear_texture(self.ctx, self._targets[1], programs=self._programs)
        self._written = True
        return self._targets[1]

    def hair_fbo(self):
        """The hardware rasteriser's framebuffer: the HDR target's colour and depth, and the
        multiply scattered light's target as a second colour (multisampled as the HDR colour is,
        resolved by ``resolve``), cleared."""
        r = self.renderer
        hdr = r.hdr_target()
        multi = r.samples > 1
        ms = self.target()
        h = self._hair
        if h is None or h.hdr is not hdr or h.ms is not ms:
            self._release_hair()
            ctx = self.ctx
            if multi:
                rb = ctx.texture(ms.size, 4, samples=r.samples, dtype="f2")   # a texture: sample_resolve reads it
                h = _HairTargets(hdr, ms, ctx.framebuffer([hdr.color, rb], hdr.depth), rb, ctx.framebuffer([rb]),
                                 ctx.framebuffer([ms]))
            else:
                h = _HairTargets(hdr, ms, ctx.framebuffer([hdr.color, ms], hdr.depth))
            self._hair = h
        if multi:
            h.samples_fbo.clear(0.0, 0.0, 0.0, 0.0)
        return h.fbo

    def resolve(self) -> None:
        """The hardware rasteriser's multisampled target averaged into ``target``'s texture."""
        if self._hair is not None and self._hair.samples is not None:
            offsets = self.renderer.sample_offsets
            if offsets is None:
                self.ctx.copy_framebuffer(self._hair.ms_fbo, self._hair.samples_fbo)
            else:   # a still frame (sample_resolve.py)
                sample_resolve.resolve(self.renderer, self._hair.samples, self._hair.ms_fbo, offsets)

    def run(self, frame: Frame) -> None:
        r = self.renderer
        if self._targets is None:
            return
        sigma = self._sigma(frame.view)
        # the single-sample colour the shading pass wrote (with a multisampled head, the resolve of it)
        hdr = r.hdr_textures()[0]
        grid = self._grid(low_size(self._targets[0], factor(sigma)))
        key = (sigma, hdr, grid)
        if self._plan is None or self._plan[0] != key:
            self._plan = (key, plan(self.ctx, self._targets[1], grid, hdr, sigma, self._programs))
        dispatch(self.ctx, self._plan[1])
        self._written = False

    def _sigma(self, view) -> float:
        """sigma_pixels at the hair's centre, kept while the view and the hair's box are the same."""
        box = self.renderer.hair_bbox()
        width = float(self.renderer.settings.ms_smoothing)
        m = self._sigma_memo
        if m is None or m[0] is not view or m[1] is not box or m[2] != width:
            centre = 0.5 * (np.asarray(box[0]) + np.asarray(box[1]))
            self._sigma_memo = m = (view, box, width, sigma_pixels(view, width, centre))
        return m[3]

    def _grid(self, size):
        if self._grids is None or self._grids[0] != size:
            if self._grids is not None:
                for t in self._grids[1]:
                    t.release()
            self._grids = (size, grid_textures(self.ctx, size))
        return self._grids[1]

    def _release_hair(self) -> None:
        if self._hair is not None:
            for obj in (self._hair.fbo, self._hair.samples_fbo, self._hair.ms_fbo, self._hair.samples):
                if obj is not None:
                    obj.release()
            self._hair = None

    def release(self) -> None:
        self._release_hair()
        held = ([] if self._targets is None else [self._targets[1]]) + ([] if self._grids is None else list(self._grids[1]))
        for t in held:
            t.release()
        self._targets = self._grids = self._plan = None


def grid_textures(ctx, size) -> tuple:
    """The reduced grid's two RGBA32F textures (a stage reads one and writes the other)."""
    return tuple(ctx.texture(tuple(size), 4, dtype="f4") for _ in range(2))


@functools.lru_cache(maxsize=16)
def _uniforms(sigma: float) -> dict:
    """smooth's uniforms, one dict per sigma (set_uniforms skips them by identity)."""
    ls = low_sigma(sigma, factor(sigma))
    return {"u_radius": taps(ls), "u_sigma": ls}


def plan(ctx, ms, grid, hdr, sigma: float, programs: ProgramMemo | None = None) -> tuple:
    """ms_smooth.comp's four dispatches as (program, uniforms, images, groups): ``ms`` (radiance
    x coverage, coverage) summed into cells of ``factor(sigma)`` pixels a side (``grid``: two
    RGBA32F textures of ``low_size``), the cells smoothed by a Gaussian of ``low_sigma`` cells
    along rows, then columns, and the result added to ``hdr``; ``ms`` is left cleared."""
    f = factor(sigma)
    u = _uniforms(float(sigma))
    a, b = grid
    steps = ((0, None, ((ms, IMG_MS, True, False), (a, IMG_MS_DST, False, True)), a.size),
             (1, u, ((a, IMG_MS_SRC, True, False), (b, IMG_MS_DST, False, True)), a.size),
             (2, u, ((b, IMG_MS_SRC, True, False), (a, IMG_MS_DST, False, True)), a.size),
             (3, None, ((ms, IMG_MS, True, True), (a, IMG_MS_SRC, True, False), (hdr, IMG_HDR, True, True)), ms.size))
    out = []
    for stage, uniforms, images, (w, h) in steps:
        def build(stage=stage):
            return _program(ctx, stage, f)
        cs = build() if programs is None else programs.get(("ms_smooth", stage, f), (), build)
        out.append((cs, uniforms, images, (math.ceil(w / 8), math.ceil(h / 8))))
    return tuple(out)


def _program(ctx, stage: int, f: int):
    return compute_shader(ctx, shader_path("ms_smooth.comp"), {"STAGE": stage, "FACTOR": f})


def compile_every_factor(ctx) -> None:
    """The four stages' programs for every grid factor: the frame's size and the hair's distance
    pick one (mane.warmup compiles them all ahead)."""
    for f in FACTORS:
        for stage in range(4):
            _program(ctx, stage, f)


def dispatch(ctx, steps) -> None:
    """Run ``plan``'s steps (the uniforms again each time: the programs are shared by sigmas of
    one cell size)."""
    for cs, uniforms, images, groups in steps:
        if uniforms is not None:
            set_uniforms(cs, uniforms)
        for tex, unit, read, write in images:
            tex.bind_to_image(unit, read=read, write=write)
        cs.run(*groups)
        ctx.memory_barrier()


def smooth(ctx, ms, grid, hdr, sigma: float, programs: ProgramMemo | None = None) -> None:
    """The smoothing of ``ms`` added to ``hdr`` (``plan``'s steps run once)."""
    dispatch(ctx, plan(ctx, ms, grid, hdr, sigma, programs))


def smooth_numpy(ms: np.ndarray, hdr: np.ndarray, sigma: float) -> np.ndarray:
    """The twin: (H, W, 4) ``ms`` (radiance x coverage, coverage) and ``hdr`` -> ``hdr`` with the
    smoothed radiance per unit of coverage times each pixel's coverage added where it has hair:
    the same cells, taps (none past the grid's edge) and bilinear interpolation (clamped to the
    grid) as ms_smooth.comp."""
    from scipy.ndimage import correlate1d

    ms = np.asarray(ms, np.float64)
    H, W = ms.shape[:2]
    f = factor(sigma)
    gw, gh = low_size((W, H), f)
    cells = np.zeros((gh * f, gw * f, 4))
    cells[:H, :W] = ms
    cells = cells.reshape(gh, f, gw, f, 4).sum(axis=(1, 3))
    ls = low_sigma(sigma, f)
    n = taps(ls)
    k = np.exp(-0.5 * (np.arange(-n, n + 1) / ls) ** 2)
    s = correlate1d(correlate1d(cells, k, axis=1, mode="constant"), k, axis=0, mode="constant")

    def axis(count, cells_n):
        u = (np.arange(count) + 0.5) / f - 0.5
        i0 = np.floor(u).astype(int)
        return np.clip(i0, 0, cells_n - 1), np.clip(i0 + 1, 0, cells_n - 1), u - i0

    x0, x1, fx = axis(W, gw)
    y0, y1, fy = axis(H, gh)
    fx, fy = fx[None, :, None], fy[:, None, None]
    top = s[y0][:, x0] * (1 - fx) + s[y0][:, x1] * fx
    bottom = s[y1][:, x0] * (1 - fx) + s[y1][:, x1] * fx
    up = top * (1 - fy) + bottom * fy
    out = np.array(hdr, np.float64)
    hair = ms[..., 3] > 0
    out[..., :3] += np.where(hair[..., None], up[..., :3] / np.maximum(up[..., 3:], 1e-6) * ms[..., 3:], 0.0)
    return out
