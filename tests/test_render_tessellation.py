"""Tessellated guide curves against NumPy twins: Catmull-Rom, uniform cubic B-spline, Bezier.

The geometry shader's CAPTURE build appends every emitted segment to a buffer; with one
strand per guide (the guide itself) the captured vertices are the curve itself.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from mane.groom import Groom
from mane.render import Renderer, RenderSettings
from mane.render.capture import capture_segments, strands_from_segments

pytestmark = pytest.mark.gpu


# ---------------------------------------------------------------- NumPy twins
def phantom(points: np.ndarray) -> np.ndarray:
    """The guide with mirrored end points: 2 P0 - P1 before, 2 Pn - Pn-1 after."""
    return np.concatenate([2 * points[:1] - points[1:2], points, 2 * points[-1:] - points[-2:-1]])


def basis(scheme: str, u: float):
    """(position weights, derivative weights) on P0..P3 for the segment P1 -> P2."""
    if scheme == "catmull_rom" or scheme == "bezier":  # the Bezier hull is Catmull-Rom's curve
        w = 0.5 * np.array([-u**3 + 2 * u**2 - u, 3 * u**3 - 5 * u**2 + 2, -3 * u**3 + 4 * u**2 + u, u**3 - u**2])
        d = 0.5 * np.array([-3 * u**2 + 4 * u - 1, 9 * u**2 - 10 * u, -9 * u**2 + 8 * u + 1, 3 * u**2 - 2 * u])
        return w, d
    v = 1 - u
    w = np.array([v**3, 3 * u**3 - 6 * u**2 + 4, -3 * u**3 + 3 * u**2 + 3 * u + 1, u**3]) / 6
    d = np.array([-0.5 * v * v, 1.5 * u * u - 2 * u, -1.5 * u * u + u + 0.5, 0.5 * u * u])
    return w, d


def bezier_segment(P, u):
    """De Casteljau on the Vulkan-hair control points (the twin of the shader's Bezier)."""
    c = [P[1], P[1] + (P[2] - P[0]) / 6, P[2] - (P[3] - P[1]) / 6, P[2]]
    pos = (1 - u) ** 3 * c[0] + 3 * (1 - u) ** 2 * u * c[1] + 3 * (1 - u) * u**2 * c[2] + u**3 * c[3]
    der = 3 * ((1 - u) ** 2 * (c[1] - c[0]) + 2 * u * (1 - u) * (c[2] - c[1]) + u**2 * (c[3] - c[2]))
    return pos, der


def curve(points: np.ndarray, scheme: str, s: np.ndarray):
    """Positions and derivatives (per unit u) at strand parameters s in [0, 1]."""
    P = phantom(points)
    segs = len(points) - 1
    x = np.clip(s, 0, 1) * segs
    i = np.minimum(np.floor(x).astype(int), segs - 1)
    u = x - i
    pos, der = [], []
    for ii, uu in zip(i, u):
        ctrl = P[ii:ii + 4]
        if scheme == "bezier":
            p, d = bezier_segment(ctrl, uu)
        else:
            w, dw = basis(scheme, uu)
            p, d = w @ ctrl, dw @ ctrl
        pos.append(p)
        der.append(d)
    return np.array(pos), np.array(der)


# ---------------------------------------------------------------- fixtures
def wavy_groom(guides: int = 3, points: int = 6) -> Groom:
    t = np.linspace(0.0, 1.0, points)
    strands = []
    for g in range(guides):
        x = 0.04 * np.cos(5 * t + g) + 0.1 * g
        z = 0.04 * np.sin(5 * t + g)
        strands.append(np.c_[x, -0.3 * t + 0.02 * t**2, z])
    return Groom.from_strands(strands)


def capture(gl, groom, **kw):
    settings = RenderSettings(size=(64, 48), msaa=1, strands_per_guide=1, **kw)
    r = Renderer(settings, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        return capture_segments(r), r.rendered_segments
    finally:
        r.release()


# ---------------------------------------------------------------- tests
@pytest.mark.parametrize("scheme", ["catmull_rom", "bspline", "bezier"])
def test_curve_matches_numpy_twin(gl, scheme):
    g = wavy_groom()
    seg, _ = capture(gl, g, interpolation=scheme, segments=40)
    strands = strands_from_segments(seg)
    assert len(strands) == g.num_strands
    for gi, pts in strands.items():
        want, _ = curve(g.as_padded()[gi].astype(np.float64), scheme, pts[:, 3])
        np.testing.assert_allclose(pts[:, :3], want, atol=2e-6)


def test_catmull_rom_passes_through_the_guide_points(gl):
    g = wavy_groom(points=7)
    seg, _ = capture(gl, g, interpolation="catmull_rom", segments=18)   # 3 subdivisions per segment
    for gi, pts in strands_from_segments(seg).items():
        k = pts[:, 3] * 6
        at_knots = np.abs(k - np.round(k)) < 1e-4
        assert at_knots.sum() == 7
        np.testing.assert_allclose(pts[at_knots, :3], g.as_padded()[gi], atol=1e-6)


def test_bspline_keeps_root_and_tip_but_approximates_the_rest(gl):
    g = wavy_groom(points=7)
    seg, _ = capture(gl, g, interpolation="bspline", segments=18)
    for gi, pts in strands_from_segments(seg).items():
        guide = g.as_padded()[gi]
        np.testing.assert_allclose(pts[0, :3], guide[0], atol=1e-6)     # phantom points: exact ends
        np.testing.assert_allclose(pts[-1, :3], guide[-1], atol=1e-6)
        k = pts[:, 3] * 6
        inner = (np.abs(k - np.round(k)) < 1e-4) & (k > 0.5) & (k < 5.5)
        assert np.linalg.norm(pts[inner, :3] - guide[1:-1], axis=1).max() > 1e-3   # smoothing, not through


def test_bezier_is_c1_at_the_joints(gl):
    g = wavy_groom(points=6)
    seg, _ = capture(gl, g, interpolation="bezier", segments=20)
    P = phantom(g.as_padded()[0].astype(np.float64))
    for j in range(1, 5):   # joints between segments j-1 and j
        _, d_left = bezier_segment(P[j - 1:j + 3], 1.0)
        _, d_right = bezier_segment(P[j:j + 4], 0.0)
        np.testing.assert_allclose(d_left, d_right, atol=1e-12)       # C1, not only G1
    # the GPU's unit tangents agree across every joint
    for gi in range(g.num_strands):
        m = seg["id"] == gi
        s0, s1, t0, t1 = seg["s0"][m], seg["s1"][m], seg["t0"][m], seg["t1"][m]
        for j in range(1, 5):
            sj = j / 5
            a = np.flatnonzero(np.abs(s1 - sj) < 1e-5)
            b = np.flatnonzero(np.abs(s0 - sj) < 1e-5)
            assert len(a) == 1 and len(b) == 1
            assert float(np.dot(t1[a[0]], t0[b[0]])) > 1 - 1e-5
    # the Vulkan hull is uniform Catmull-Rom written as Bezier: same curve
    seg_cr, _ = capture(gl, g, interpolation="catmull_rom", segments=20)
    np.testing.assert_allclose(np.sort(seg["p0"], axis=0), np.sort(seg_cr["p0"], axis=0), atol=2e-6)


@pytest.mark.parametrize("scheme", ["catmull_rom", "bspline"])
def test_tangents_are_the_drawn_curves_direction(gl, scheme):
    # the shading tangent at a drawn point: the direction from the curve's point a segment
    # before to the one a segment after (the NumPy twin's), at the root the first segment's; it
    # converges to the derivative as the segments shorten (within 2 degrees here, 30 segments)
    g = wavy_groom()
    seg, _ = capture(gl, g, interpolation=scheme, segments=30)
    for gi in range(g.num_strands):
        m = seg["id"] == gi
        s0, step = seg["s0"][m].astype(np.float64), (seg["s1"][m] - seg["s0"][m]).astype(np.float64)
        pts = g.as_padded()[gi].astype(np.float64)
        before, _ = curve(pts, scheme, np.maximum(s0 - step, 0.0))
        after, der = curve(pts, scheme, s0 + step)
        here, der = curve(pts, scheme, s0)
        want = after - before
        want /= np.linalg.norm(want, axis=1, keepdims=True)
        assert np.einsum("ij,ij->i", seg["t0"][m], want).min() > 1 - 1e-5
        der /= np.linalg.norm(der, axis=1, keepdims=True)
        inner = s0 > 0
        assert np.einsum("ij,ij->i", seg["t0"][m][inner], der[inner]).min() > math.cos(math.radians(2.0))
        # smooth: consecutive tangents turn little
        order = np.argsort(s0)
        t = seg["t0"][m][order]
        assert np.einsum("ij,ij->i", t[1:], t[:-1]).min() > math.cos(math.radians(25))


@pytest.mark.parametrize("segments,points,expect_sub", [(8, 5, 2), (30, 7, 5), (1, 4, 1), (500, 3, 64)])
def test_segments_per_strand(gl, segments, points, expect_sub):
    g = wavy_groom(guides=2, points=points)
    seg, rendered = capture(gl, g, segments=segments)
    assert seg["count"] == rendered == 2 * (points - 1) * expect_sub
