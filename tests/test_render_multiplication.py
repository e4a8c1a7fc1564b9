"""Strand multiplication beyond single-strand clumps, against NumPy twins (mane.render.strand_math):
3-guide barycentric interpolation (Woodhouse), the hybrid's collider fallback, the Vulkan hair's
five stray profiles (probability 0.5, equiprobable shapes), render-time curl and distance LOD
(Chen's segments, TressFX 4.1's density and width)."""
from __future__ import annotations

import numpy as np
import pytest

from mane.groom import Groom
from mane.render import Camera, Renderer, RenderSettings
from mane.render import strand_math as sm
from mane.render.capture import capture_segments, strands_from_segments
from mane.render.multi_strand import ellipsoid_sdf, straddle_flags

pytestmark = pytest.mark.gpu

BASE = dict(size=(64, 48), msaa=1, shadows="none", stray_fraction=0.0, segments=20)


def wavy_groom(guides: int = 3, points: int = 6, spacing: float = 0.02) -> Groom:
    t = np.linspace(0.0, 1.0, points)
    return Groom.from_strands([np.c_[0.03 * np.cos(4 * t + g) + spacing * g, -0.25 * t, 0.03 * np.sin(4 * t + g)]
                               for g in range(guides)])


def capture(gl, groom, weights=None, camera=None, colliders=None, **kw):
    r = Renderer(RenderSettings(**{**BASE, **kw}), ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        if weights is not None:
            r.set_guide_weights(*weights)
        if colliders is not None:
            r.set_colliders(ellipsoids=colliders)
        seg = capture_segments(r, camera)
        table = r._strand_table
        flags = None if table is None else table.flags.copy()
        return seg, flags
    finally:
        r.release()


def guide_curves(gl, groom, **kw):
    """Each guide's tessellated curve (single mode, one strand per guide): id -> (K, 4) xyz s."""
    seg, _ = capture(gl, groom, strands_per_guide=1, **kw)
    return strands_from_segments(seg)


# ---------------------------------------------------------------- multi-strand
def test_blend_of_three_identical_guides_is_the_guide(gl):
    one = wavy_groom(guides=1)
    g = Groom.from_strands([one.as_padded()[0]] * 3)
    rng = np.random.default_rng(1)
    w = rng.dirichlet([1, 1, 1], size=20)
    idx = np.tile([0, 1, 2], (20, 1))
    seg, _ = capture(gl, g, weights=(idx, w), interpolation_mode="multi")
    want = guide_curves(gl, g)[0]
    got = strands_from_segments(seg)
    assert len(got) == 20
    for pts in got.values():
        np.testing.assert_allclose(pts[:, 3], want[:, 3], atol=1e-6)
        np.testing.assert_allclose(pts[:, :3], want[:, :3], atol=2e-6)


def test_unit_weight_reproduces_guide_zero_plus_offset(gl):
    g = wavy_groom(guides=3)
    off = np.array([[0.01, 0.02, -0.005], [0.0, 0.0, 0.0]])
    idx = np.array([[0, 1, 2], [2, 0, 1]])
    w = np.array([[1.0, 0.0, 0.0], [0.2, 0.5, 0.3]])
    seg, _ = capture(gl, g, weights=(idx, w, off), interpolation_mode="multi")
    curves = guide_curves(gl, g)
    got = strands_from_segments(seg)
    np.testing.assert_allclose(got[0][:, :3], curves[0][:, :3] + off[0], atol=2e-6)
    # any weights: the blend of the 3 curves (the curve is linear in its control points)
    want = sm.blend_guides([curves[2][:, :3], curves[0][:, :3], curves[1][:, :3]], w[1])
    np.testing.assert_allclose(got[1][:, :3], want, atol=2e-6)


def test_procedural_multi_is_stable_and_keeps_the_guides(gl):
    g = wavy_groom(guides=4)
    a, _ = capture(gl, g, interpolation_mode="multi", strands_per_guide=6)
    b, _ = capture(gl, g, interpolation_mode="multi", strands_per_guide=6)
    # the geometry shader appends segments with an atomic counter: the capture order follows
    # the GPU's scheduling (fixed on llvmpipe, not on NVIDIA), so compare per (strand, s)
    order = lambda s: np.lexsort((s["s0"], s["id"]))  # noqa: E731
    assert a["count"] == b["count"]
    for key in ("id", "s0", "s1", "p0", "p1"):
        np.testing.assert_array_equal(a[key][order(a)], b[key][order(b)])
    curves = guide_curves(gl, g)
    got = strands_from_segments(a)
    assert len(got) == 24
    for gi in range(4):      # strand 0 of every guide has the weights (1, 0, 0)
        np.testing.assert_allclose(got[gi * 6][:, :3], curves[gi][:, :3], atol=2e-6)


def straddle_groom():
    """Guides 0 and 1 root 2 cm apart and part around a sphere below them; 2 and 3 stay left."""
    t = np.linspace(0.0, 1.0, 8)
    def strand(x0, side, z=0.0):
        return np.c_[x0 + side * 0.06 * np.sin(np.pi * t / 1.6), -0.2 * t, np.full_like(t, z)]
    return Groom.from_strands([strand(-0.01, -1), strand(0.01, 1), strand(-0.015, -1, 0.005),
                               strand(-0.02, -1, -0.004)])


SPHERE = (0.0, -0.1, 0.0, 0.03, 0.03, 0.03)


def test_hybrid_falls_back_where_guides_straddle_a_sphere(gl):
    g = straddle_groom()
    idx = np.array([[0, 1, 2], [0, 2, 3]])
    w = np.array([[0.6, 0.4, 0.0], [0.5, 0.3, 0.2]])
    pos = g.as_padded().astype(np.float64)
    flags = straddle_flags(pos, idx, w, ellipsoid_sdf([SPHERE]), margin=0.002)
    assert flags.tolist() == [True, False]                 # the NumPy decision
    centre = np.array(SPHERE[:3])
    out = {}
    for mode in ("multi", "hybrid"):
        seg, f = capture(gl, g, weights=(idx, w), interpolation_mode=mode, colliders=[SPHERE], clump_tip=1.0)
        out[mode] = strands_from_segments(seg)
        if mode == "hybrid":
            assert f.tolist() == [1, 0]
    dist = lambda pts: np.linalg.norm(pts[:, :3] - centre, axis=1).min()  # noqa: E731
    assert dist(out["multi"][0]) < 0.03                    # the blend cuts through the sphere
    assert dist(out["hybrid"][0]) > 0.03                   # the fallback goes round it
    root = w[0] @ pos[idx[0], 0]
    np.testing.assert_allclose(out["hybrid"][0][0, :3], root, atol=1e-6)    # from its own root
    np.testing.assert_allclose(out["hybrid"][1], out["multi"][1], atol=1e-7)  # the other is blended
    # with clump_tip = 1 the offset in the guide's frame keeps its length along the strand
    curves = guide_curves(gl, g)
    gap = np.linalg.norm(out["hybrid"][0][:, :3] - curves[0][:, :3], axis=1)
    np.testing.assert_allclose(gap, np.linalg.norm(root - pos[0, 0]), atol=2e-5)


# ---------------------------------------------------------------- strays
def test_stray_profiles_formulas():
    s = np.linspace(0, 1, 11)
    G = lambda m: np.exp(-(s - m) ** 2 / 0.08)  # noqa: E731
    want = [1.8 * G(0.25), 2.5 * G(0.7), 1.8 * G(0.8), 4.5 * s ** 10, 4.0 * s ** 1.3]
    for k in range(5):
        np.testing.assert_allclose(sm.stray_profile(k, s), np.asarray(want[k]) / 4.5, atol=1e-12)
    assert sm.stray_profile(3, 1.0) == pytest.approx(1.0)           # stray_amount = the most
    assert np.argmax(sm.stray_profile(0, s)) < np.argmax(sm.stray_profile(1, s))   # root vs lower


def test_stray_probabilities_over_many_strands():
    n = 200_000
    r = sm.strand_randoms(np.repeat(np.arange(2000), 100), np.tile(np.arange(100), 2000))
    dev = r["stray"] < 0.5
    tol = 4 * np.sqrt(0.25 / n)
    assert abs(dev.mean() - 0.5) < tol
    k = sm.stray_profile_index(r["shape"][dev])
    for j in range(5):
        p = (k == j).mean()
        assert abs(p - 0.2) < 4 * np.sqrt(0.16 / dev.sum())       # equiprobable among deviators
        assert abs((dev & (sm.stray_profile_index(r["shape"]) == j)).mean() - 0.1) < 4 * np.sqrt(0.09 / n)


def test_gpu_strays_match_the_twin(gl):
    g = wavy_groom(guides=2, points=6)
    spg = 300
    settings = RenderSettings(**{**BASE, "stray_fraction": 0.5, "stray_amount": 2.0, "clump_radius": 0.005,
                                 "strands_per_guide": spg})
    seg, _ = capture(gl, g, **{**BASE, "stray_fraction": 0.5, "stray_amount": 2.0, "clump_radius": 0.005,
                               "strands_per_guide": spg})
    strands = strands_from_segments(seg)
    guide = {gi: strands[gi * spg] for gi in range(2)}
    ids = np.array(sorted(strands))
    gi, j = ids // spg, ids % spg
    rnd = sm.strand_randoms(gi, j)
    deviating, shapes = [], []
    for n, sid in enumerate(ids):
        if j[n] == 0:
            continue
        pts = strands[sid]
        got = np.linalg.norm(pts[:, :3] - guide[gi[n]][:, :3], axis=1)
        one = {k: v[n] for k, v in rnd.items()}
        want = sm.clump_radius_at(pts[:, 3], one, settings)
        np.testing.assert_allclose(got, want, atol=3e-6)
        base = 0.005 * np.sqrt(one["radius"]) * sm.clump_taper(pts[:, 3], settings.clump_root, settings.clump_tip)
        extra = (got - base) / (0.005 * 2.0)
        if np.abs(extra).max() > 1e-3:
            deviating.append(sid)
            err = [np.abs(extra - sm.stray_profile(k, pts[:, 3])).max() for k in range(5)]
            shapes.append(int(np.argmin(err)))
    n = len(ids) - 2
    assert abs(len(deviating) / n - 0.5) < 4 * np.sqrt(0.25 / n)
    counts = np.bincount(shapes, minlength=5) / n
    assert np.all(np.abs(counts - 0.1) < 4 * np.sqrt(0.09 / n)), counts


# ---------------------------------------------------------------- curl
def test_curl_radius_matches_the_setting(gl):
    g = wavy_groom(guides=2, points=8)
    kw = dict(strands_per_guide=5, clump_radius=0.004, segments=70)
    plain, _ = capture(gl, g, **kw)
    curled, _ = capture(gl, g, curl_radius=0.003, curl_frequency=5.0, **kw)
    a, b = strands_from_segments(plain), strands_from_segments(curled)
    for sid in a:
        s = a[sid][:, 3]
        d = b[sid][:, :3] - a[sid][:, :3]
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 0.003 * sm.curl_ramp(s), atol=2e-6)
        # perpendicular to the uncurled curve, and turning 5 times along the strand
        t = np.gradient(a[sid][:, :3], axis=0)
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        far = s > 0.15
        assert np.abs(np.einsum("ij,ij->i", d[far], t[far])).max() < 0.003 * 0.05
        u = d[far] / np.linalg.norm(d[far], axis=1, keepdims=True)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", u[1:], u[:-1]), -1, 1)).sum() / (2 * np.pi)
        assert turn == pytest.approx(5.0 * (s[far][-1] - s[far][0]), rel=0.08)


# ---------------------------------------------------------------- LOD
LOD = dict(lod=True, lod_start=0.5, lod_end=2.5, lod_percent=0.5, lod_width_multiplier=2.0,
           lod_segment_percent=0.25, lod_min_segments=4, min_pixel_width=0.0)


def lod_sweep(gl, distances, groom, **kw):
    out = []
    for d in distances:
        cam = Camera(eye=(0.0, -0.1, float(d)), target=(0.0, -0.1, 0.0), near=0.01, far=10.0)
        seg, _ = capture(gl, groom, camera=cam, **{**LOD, **kw})
        out.append(seg)
    return out


def test_lod_twin_is_monotonic_and_continuous():
    s = RenderSettings(**LOD, segments=32)
    d = np.linspace(0.0, 4.0, 4001)
    f = sm.lod_factors(d, s)
    for key in ("density", "segments"):
        assert np.all(np.diff(f[key]) <= 1e-12)
        assert np.abs(np.diff(f[key])).max() <= np.abs(f[key][0] - f[key][-1]) / (2.0 / 0.001) + 1e-9
    assert f["density"][-1] == pytest.approx(0.5) and f["width"][-1] == pytest.approx(2.0)
    cov = f["density"] * f["width"]      # TressFX's compensation: coverage stays within 1..1.125
    assert cov.min() >= 1.0 - 1e-12 and cov.max() <= 1.125 + 1e-12


def test_lod_counts_fall_continuously_with_distance(gl):
    g = wavy_groom(guides=2, points=6, spacing=0.004)
    spg = 16
    distances = np.linspace(0.3, 3.0, 28)
    segs = lod_sweep(gl, distances, g, strands_per_guide=spg, segments=40)
    s = RenderSettings(**{**BASE, **LOD, "segments": 40})
    roots = g.as_padded()[:, 0].astype(np.float64)
    n_strands, n_segments, eff, coverage = [], [], [], []
    for d, seg in zip(distances, segs):
        eye = np.array([0.0, -0.1, d])
        dist = np.linalg.norm(roots - eye, axis=1)
        f = sm.lod_factors(dist, s)
        lines, alpha = sm.lod_strands(f["density"], spg)
        per = sm.odd_spacing_count(sm.lod_level(dist, s, 6))
        ids = np.unique(seg["id"])
        assert len(ids) == lines.sum()                               # strands drawn: the twin's
        guide_segs = [(seg["id"] == gi * spg).sum() for gi in range(2)]
        assert guide_segs == list(5 * per)                           # fractional_odd segments: the twin's
        a = np.array([seg["alpha0"][seg["id"] == i][0] for i in ids])
        np.testing.assert_allclose(np.sort(a), np.sort(alpha[alpha > 0]), atol=1e-5)
        n_strands.append(len(ids))
        n_segments.append(seg["count"])
        eff.append(a.sum())
        length = np.linalg.norm(seg["p1"] - seg["p0"], axis=1)
        coverage.append(float((seg["alpha0"] * seg["width"][:, 0] * length).sum()))
    assert np.all(np.diff(n_strands) <= 0) and np.all(np.diff(n_segments) <= 0)
    # continuous: effective strands (sum of fades) change by at most the twin's slope x step
    step = spg * 0.5 / 2.0 * (distances[1] - distances[0]) * 2 + 1e-3
    assert np.abs(np.diff(eff)).max() <= step
    assert eff[0] == pytest.approx(2 * spg) and eff[-1] == pytest.approx(2 * spg * 0.5, abs=1e-3)
    # width compensation keeps the hair's coverage (alpha x width x length) roughly constant
    cov = np.array(coverage) / coverage[0]
    assert cov.min() > 0.93 and cov.max() < 1.2
    plain = lod_sweep(gl, [distances[-1]], g, strands_per_guide=spg, segments=40, lod_width_multiplier=1.0)[0]
    length = np.linalg.norm(plain["p1"] - plain["p0"], axis=1)
    assert (plain["alpha0"] * plain["width"][:, 0] * length).sum() / coverage[0] < 0.6


def test_lod_geometry_is_continuous_between_levels(gl):
    """Fractional tessellation: a small step in distance moves the strand's polyline little."""
    g = wavy_groom(guides=1, points=6)
    a, b = lod_sweep(gl, [1.30, 1.31], g, strands_per_guide=1, segments=40)
    pa, pb = strands_from_segments(a)[0], strands_from_segments(b)[0]
    # resample both polylines by s and compare
    s = np.linspace(0, 1, 200)
    ra = np.stack([np.interp(s, pa[:, 3], pa[:, i]) for i in range(3)], 1)
    rb = np.stack([np.interp(s, pb[:, 3], pb[:, i]) for i in range(3)], 1)
    assert np.linalg.norm(ra - rb, axis=1).max() < 1e-3
