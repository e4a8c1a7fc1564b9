"""A still picture's frames on the hardware rasteriser, resolved to a box filter.

A still picture (passes/accumulate.py) moves each frame's image by a sub-pixel offset d and
averages the frames, so that a pixel's samples spread over it as a path tracer's do (a box
filter, Mitsuba's ``box`` rfilter in mane.reference). The compute rasteriser's samples lie on a
regular grid, so moving them within a sample's cell covers the pixel evenly. The raster units'
samples do not: GL's 4x pattern is a rotated grid ((3/8, 1/8), (7/8, 3/8), (1/8, 5/8), (5/8, 7/8)),
and moved within cells of a regular grid each sample's cell sat an eighth of a pixel off its
own, a quarter of the filter outside the pixel and as much of it missing (Sintel brown against
the path tracer: 0.316 relative error per pixel against the compute rasteriser's 0.296; the same
64 samples at one sample a pixel, a box: 0.300; docs/quality.md).

Here the frame's image moves by d anywhere in a pixel, and each pixel takes, for each sample i,
the sample i of the pixel whose sample fell inside it: sample i of pixel q sees the unmoved
image at q + s_i - d (s_i its position in the pixel), so pixel p takes it from
q = p + offset_i, offset_i = -floor(s_i - d), at the point p + frac(s_i - d): every point a
pixel's mean holds lies in it, whatever the pattern. ``resolve_numpy`` is the resolve's twin.

The offsets d (``jitter``) spread those points evenly: the frames come in rounds of ``ROUND``;
a round's points are to fill a G x G grid of cells (G^2 about samples x ROUND), each frame's d
the cell translation whose samples land in cells the round has not filled yet (the first such,
else the fewest filled), plus the round's Halton (2, 3) point within a cell (round r's the r-th:
a cell's points over the rounds stratified in it too). GL's 4x pattern
lies on the eighths, so its 16 frames fill the 8 x 8 cells once each (64 samples a pixel, as
stratified as the compute rasteriser's). Plain Halton offsets over the pixel, shared by the four
samples, filled them unevenly (cells of 0 to 3 points after 16 frames), and on thin hair gave
more noise at 16 frames than the cells of a regular grid did.
"""
from __future__ import annotations

import functools
import math

import moderngl
import numpy as np

from ...errors import GLFeatureError
from ...gpu.glsl import program
from ..bindings import TEX_MS_RESOLVE
from .accumulate import halton
from .base import set_uniform, shader_path

ROUND = 16   # frames whose samples fill the cells once (accumulate's default)


def jitter(positions: np.ndarray, k: int) -> tuple[float, float]:
    """The k-th still frame's image offset (k >= 1), in pixels, in [-0.5, 0.5), for samples at
    ``positions`` ((n, 2) in the pixel): see the module's doc."""
    pos = tuple(map(tuple, np.asarray(positions, np.float64).tolist()))
    d = _round(pos, (int(k) - 1) // ROUND)[(int(k) - 1) % ROUND]
    return float(d[0]), float(d[1])


@functools.lru_cache(maxsize=64)
def _round(positions: tuple, r: int) -> np.ndarray:
    """Round r's ROUND offsets (frames r * ROUND + 1 ...)."""
    s = np.array(positions, np.float64)
    n = len(s)
    g = max(1, int(round(math.sqrt(n * ROUND))))
    filled = np.zeros((g, g), np.int64)
    cells = np.stack(np.meshgrid(np.arange(g), np.arange(g)), -1).reshape(-1, 2) / g   # the translations
    out = np.empty((ROUND, 2))
    eps = np.array([halton(r + 1, 2), halton(r + 1, 3)]) / g   # the round's point in a cell
    d = cells + eps - 0.5                                       # (g*g, 2), in [-0.5, 0.5)
    c = np.minimum((np.mod(s[None, :, :] - d[:, None, :], 1.0) * g).astype(np.int64), g - 1)   # (g*g, n, 2)
    clash = np.array([len(set(row)) < n for row in (c[..., 1] * g + c[..., 0]).tolist()]) * n   # two in a cell
    for j in range(ROUND):
        best = int(np.argmin(filled[c[..., 1], c[..., 0]].sum(axis=1) + clash))
        np.add.at(filled, (c[best, :, 1], c[best, :, 0]), 1)
        out[j] = d[best]
    return out


def offsets(positions: np.ndarray, jitter) -> np.ndarray:
    """(n, 2) int: the pixel each sample is fetched from, relative to the pixel resolved, for a
    frame moved by ``jitter`` (dx, dy) pixels; ``positions``: (n, 2) samples' positions in the
    pixel, window axes (x right, y up)."""
    d = np.asarray(jitter, np.float64).reshape(1, 2)
    return -np.floor(np.asarray(positions, np.float64) - d).astype(np.int32)


def resolve_numpy(samples: np.ndarray, offsets_: np.ndarray) -> np.ndarray:
    """The twin of ``resolve``: ``samples`` (h, w, n, c), row 0 at the bottom (GL's), each pixel
    the mean of sample i of the pixel ``offsets_[i]`` away, clamped to the image."""
    h, w, n, _ = samples.shape
    ys, xs = np.mgrid[0:h, 0:w]
    out = np.zeros(samples.shape[:2] + samples.shape[3:], np.float64)
    for i in range(n):
        ox, oy = int(offsets_[i][0]), int(offsets_[i][1])
        out += samples[np.clip(ys + oy, 0, h - 1), np.clip(xs + ox, 0, w - 1), i]
    return out / n


def _resolve_program(ctx, samples: int, positions: bool = False):
    return program(ctx, vertex=shader_path("fullscreen.vert"), fragment=shader_path("sample_resolve.frag"),
                   defines={"SAMPLES": int(samples), "POSITIONS": int(positions)})


def _draw(ctx, vao) -> None:
    """A fullscreen triangle with no blending and no depth test (the resolved target's depth kept);
    the depth test on again after, as the passes leave it."""
    ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
    vao.render(moderngl.TRIANGLES, vertices=3)
    ctx.enable(moderngl.DEPTH_TEST)


def sample_positions(renderer) -> np.ndarray:
    """(samples, 2): where the GPU puts the renderer's samples in a pixel (renderer.samples), window
    axes, in [0, 1): each sample writes gl_SamplePosition into a one-pixel target, read back once."""
    ctx, n = renderer.ctx, int(renderer.samples)
    key = ("sample_positions", n)
    if key in renderer.memo:
        return renderer.memo[key]
    ms = ctx.texture((1, 1), 4, samples=n, dtype="f4")
    out = ctx.texture((n, 1), 4, dtype="f4")
    fbos = (ctx.framebuffer([ms]), ctx.framebuffer([out]))
    try:
        write = program(ctx, vertex=shader_path("fullscreen.vert"), fragment=shader_path("sample_positions.frag"))
        read = _resolve_program(ctx, n, positions=True)
        fbos[0].use()
        fbos[0].clear(0.0, 0.0, 0.0, 0.0)
        _draw(ctx, renderer.empty_vao(write))
        fbos[1].use()
        ms.use(TEX_MS_RESOLVE)
        set_uniform(read, "u_src", TEX_MS_RESOLVE)
        _draw(ctx, renderer.empty_vao(read))
        got = np.frombuffer(out.read(), np.float32).reshape(n, 4)
    finally:
        for obj in (*fbos, ms, out):
            obj.release()
    if not (np.array_equal(got[:, 2], np.arange(n)) and np.all((got[:, :2] >= 0.0) & (got[:, :2] < 1.0))):
        raise GLFeatureError(f"the GPU's {n}-sample positions came back as {got[:, :3].tolist()}, not one "
                             f"place in the pixel per sample: a still picture at msaa {n} cannot be resolved")
    renderer.memo[key] = got[:, :2].astype(np.float64)
    return renderer.memo[key]


def resolve(renderer, src, dst_fbo, offsets_: np.ndarray) -> None:
    """``src`` (a multisampled texture) resolved into ``dst_fbo``'s colour: each pixel the mean of
    sample i of the pixel ``offsets_[i]`` away (``offsets``), clamped to the image."""
    ctx = renderer.ctx
    prog = _resolve_program(ctx, int(src.samples))
    set_uniform(prog, "u_src", TEX_MS_RESOLVE)
    set_uniform(prog, "u_offset", np.ascontiguousarray(offsets_, np.int32).tobytes())   # ivec2s, as bytes
    src.use(TEX_MS_RESOLVE)
    dst_fbo.use()
    _draw(ctx, renderer.empty_vao(prog))
