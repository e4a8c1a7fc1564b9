"""NumPy twins of the strand-multiplication maths in the tessellation shaders (hair.tese,
strand_common.glsl), for tests and for CPU-side decisions (hybrid flags, LOD counts).

    seed = strand_seed(guide, strand)                 # the shader's per-strand PCG hash
    r = strand_randoms(guide, strand)                 # the shader's draws, in order
    stray_profile(k, s)                               # the five deviation shapes (Rapp / Vulkan hair)
    lod_factors(distance, settings)                   # (t, density, width multiplier, segment level)
    blend_guides(curves, weights, offset)             # 3-guide barycentric blend (Woodhouse)

Strays (Vulkan hair, after Rapp 2014, as its README states): a strand deviates with
probability ``stray_fraction`` (0.5 in the seed) and then takes one of five equiprobable
shapes. The shapes' formulas are the Vulkan code's (``G(m) = exp(-(s - m)^2 / (2 * 0.2^2))``):

    0  Gaussian near the root        1.8 G(0.25)
    1  lower Gaussian                2.5 G(0.7)
    2  lower Gaussian, other scale   1.8 G(0.8)
    3  sharp exponential (flyaways)  4.5 s^10
    4  gradual exponential           4.0 s^1.3

divided by 4.5 (the largest peak) so that ``stray_amount`` is the most a stray leaves its
clump, in clump radii. The code picked them with ``rc = rand * rand`` (deviation ~15%, shapes
not equiprobable); here one uniform draw decides deviation and another the shape.
"""
from __future__ import annotations

import numpy as np

U32 = np.uint32
STRAY_SIGMA = 0.2
STRAY_PEAK = 4.5
STRAY_PROFILES = ("root_gaussian", "lower_gaussian", "lower_gaussian_wide", "sharp_exponential",
                  "gradual_exponential")
NUM_PROFILES = len(STRAY_PROFILES)
CURL_RAMP = 0.1     # curl radius grows from 0 at the root to full at s = CURL_RAMP (smoothstep)
MULTI_LOD_FADE = 0.05


def pcg_hash(v):
    v = np.asarray(v, dtype=np.uint64) & 0xFFFFFFFF
    state = (v * 747796405 + 2891336453) & 0xFFFFFFFF
    word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) & 0xFFFFFFFF
    return ((word >> 22) ^ word).astype(U32)


def strand_seed(guide, strand):
    g = np.asarray(guide, dtype=np.uint64)
    inner = pcg_hash(np.asarray(strand, dtype=np.uint64) + 0x9E3779B9).astype(np.uint64)
    return pcg_hash((g * 9781 + inner) & 0xFFFFFFFF)


def _rand_stream(seed, count: int) -> np.ndarray:
    """(count, ...) uniforms in [0, 1): the shader's successive rand01(seed) draws."""
    out = []
    s = np.asarray(seed, dtype=U32)
    for _ in range(count):
        s = pcg_hash(s)
        out.append((s >> 8).astype(np.float64) / 16777216.0)
    return np.stack(out)


RAND_NAMES = ("radius", "angle", "stray", "shape", "rand", "curl_phase", "lod")


def strand_randoms(guide, strand) -> dict:
    """The per-strand draws of hair.tese in their order: radius, angle, stray, shape, rand,
    curl_phase, lod (arrays shaped like ``guide``/``strand`` broadcast)."""
    g, s = np.broadcast_arrays(np.asarray(guide), np.asarray(strand))
    r = _rand_stream(strand_seed(g, s), len(RAND_NAMES))
    return dict(zip(RAND_NAMES, r))


def stray_profile_index(shape_rand) -> np.ndarray:
    return np.minimum((np.asarray(shape_rand) * NUM_PROFILES).astype(int), NUM_PROFILES - 1)


def stray_profile(k, s) -> np.ndarray:
    """Deviation of shape ``k`` at strand parameter ``s`` (root 0 .. tip 1), peak 1 over all."""
    k = np.asarray(k)
    s = np.asarray(s, dtype=np.float64)

    def G(m):
        return np.exp(-(s - m) ** 2 / (2.0 * STRAY_SIGMA ** 2))

    shapes = [1.8 * G(0.25), 2.5 * G(0.7), 1.8 * G(0.8), 4.5 * s ** 10, 4.0 * s ** 1.3]
    out = np.choose(np.broadcast_to(k, np.broadcast(k, s).shape), [np.broadcast_to(x, np.broadcast(k, s).shape)
                                                                  for x in shapes])
    return out / STRAY_PEAK


def clump_taper(s, root: float, tip: float) -> np.ndarray:
    s = np.asarray(s, dtype=np.float64)
    return (1 - s) * ((1 - s) * root + s) + s * ((1 - s) + s * tip)


def clump_radius_at(s, rnd: dict, settings) -> np.ndarray:
    """Distance of a strand from its guide's curve at ``s`` (the disc offset, strays included,
    curl excluded)."""
    base = settings.clump_radius * np.sqrt(rnd["radius"]) * clump_taper(s, settings.clump_root, settings.clump_tip)
    dev = rnd["stray"] < settings.stray_fraction
    extra = settings.clump_radius * settings.stray_amount * stray_profile(stray_profile_index(rnd["shape"]), s)
    return base + np.where(dev, extra, 0.0)


def curl_ramp(s) -> np.ndarray:
    x = np.clip(np.asarray(s, dtype=np.float64) / CURL_RAMP, 0.0, 1.0)
    return x * x * (3 - 2 * x)


# ---------------------------------------------------------------- LOD (Chen segments, TressFX 4.1 density/width)
def lod_t(distance, settings) -> np.ndarray:
    d = np.asarray(distance, dtype=np.float64)
    if not settings.lod:
        return np.zeros_like(d)
    span = max(float(settings.lod_end) - float(settings.lod_start), 1e-6)
    return np.clip((d - float(settings.lod_start)) / span, 0.0, 1.0)


def lod_factors(distance, settings) -> dict:
    """t (0 near .. 1 far), density (fraction of strands kept), width multiplier and the
    segments per strand wanted (a float: fractional tessellation)."""
    t = lod_t(distance, settings)
    density = 1.0 + (float(settings.lod_percent) - 1.0) * t
    width = 1.0 + (float(settings.lod_width_multiplier) - 1.0) * t
    segs = float(settings.segments) * (1.0 + (float(settings.lod_segment_percent) - 1.0) * t)
    segs = np.maximum(segs, float(settings.lod_min_segments))
    return {"t": t, "density": density, "width": width, "segments": segs}


def lod_level(distance, settings, points_per_strand: int) -> np.ndarray:
    """The tessellation level (segments per guide segment, before fractional_odd rounding)."""
    f = lod_factors(distance, settings)
    return np.clip(f["segments"] / max(1, points_per_strand - 1), 1.0, 63.0)


def odd_spacing_count(level) -> np.ndarray:
    """Segments fractional_odd_spacing makes of a level: the next odd integer (>= 1)."""
    lv = np.clip(np.asarray(level, dtype=np.float64), 1.0, 63.0)
    n = np.ceil(lv)
    return np.where(n % 2 == 0, n + 1, n).astype(int)


def lod_strands(density, strands_per_guide: int, keep_guide: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Single-strand mode: strand j of a guide has LOD alpha clamp(c - j, 0, 1), c = density * spg
    (the guide's own strand 0 stays); returns (lines drawn, alpha per strand)."""
    c = np.asarray(density, dtype=np.float64) * strands_per_guide
    j = np.arange(strands_per_guide)
    alpha = np.clip(c[..., None] - j, 0.0, 1.0)
    if keep_guide:
        alpha[..., 0] = 1.0
    lines = np.clip(np.ceil(c - 1e-6), 1, strands_per_guide).astype(int)
    return lines, alpha


def lod_segments_drawn(roots, eye, settings, points_per_strand: int, subdivisions: int,
                       tessellation: bool = False) -> int:
    """Segments the single-strand LOD draws: every guide (root (G, 3), camera at ``eye``) has its
    level clamp(wanted / (N - 1), 1, subdivisions) per guide segment; the compute expansion
    (strand_expand.comp) draws ceil(level) of its ``subdivisions`` segments (the rest collapse
    to the tip), the tessellator (fractional_odd_spacing) the next odd integer; strand j of a
    guide is drawn while its LOD alpha clamp(c - j, 0, 1) > 0, c = density * strands per guide
    (the guide's own strand 0 always with keep_guide)."""
    roots = np.asarray(roots, dtype=np.float64).reshape(-1, 3)
    d = np.linalg.norm(roots - np.asarray(eye, dtype=np.float64), axis=1)
    f = lod_factors(d, settings)
    n = max(1, points_per_strand - 1)
    level = np.clip(f["segments"] / n, 1.0, float(subdivisions))
    per = odd_spacing_count(level) if tessellation else np.ceil(level - 1e-9).astype(int)
    spg = int(settings.strands_per_guide)
    c = f["density"] * spg
    j = np.arange(spg)
    drawn = c[:, None] - j[None, :] > 0
    if settings.keep_guide:
        drawn[:, 0] = True
    return int((drawn.sum(axis=1) * per * n).sum())


# ---------------------------------------------------------------- multi-strand (Woodhouse)
def blend_guides(curves, weights, offset=None) -> np.ndarray:
    """Sum_i w_i curve_i (+ offset): curves (3, M, 3), weights (3,), offset (3,)."""
    c = np.asarray(curves, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    out = np.tensordot(w, c, axes=(0, 0))
    if offset is not None:
        out = out + np.asarray(offset, dtype=np.float64)
    return out


def random_barycentrics(a, b) -> np.ndarray:
    """Uniform points of a triangle from two uniforms: (1 - sqrt a, sqrt a (1 - b), sqrt a b)."""
    sa = np.sqrt(np.asarray(a, dtype=np.float64))
    b = np.asarray(b, dtype=np.float64)
    return np.stack([1 - sa, sa * (1 - b), sa * b], axis=-1)
