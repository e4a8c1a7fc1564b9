"""Procedural styles: curls and waves of the requested size, droop, clumps, no hair in the head."""
from __future__ import annotations

import time

import numpy as np
import pytest

from mane.errors import ManeError
from mane.grooming.head import default_head
from mane.grooming.styles import PRESETS, StyleSettings, grow, style_settings
from mane.mesh import Mesh


@pytest.fixture(scope="module")
def head():
    return default_head()


def plane(half=0.05, n=11):
    """A square in the XZ plane at y = 0, facing +Y."""
    x = np.linspace(-half, half, n)
    X, Z = np.meshgrid(x, x, indexing="ij")
    v = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], axis=1)
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([c, b, d], 1)])  # (x,z)->(x,z+1)->(x+1,z): +Y
    return Mesh(v, faces)


UPRIGHT = dict(droop=0.0, direction_jitter=0.0, sweep=0.0, clump_strength=0.0, length_variation=0.0)


def fit_circle(xy):
    """Least-squares (Kasa) circle through 2D points: centre, radius."""
    A = np.column_stack([2 * xy[:, 0], 2 * xy[:, 1], np.ones(len(xy))])
    b = (xy ** 2).sum(axis=1)
    cx, cy, c = np.linalg.lstsq(A, b, rcond=None)[0]
    return np.array([cx, cy]), np.sqrt(c + cx * cx + cy * cy)


def test_plane_faces_up():
    assert np.allclose(plane().face_normals(), [0, 1, 0])


@pytest.mark.parametrize("radius,pitch", [(0.006, 0.02), (0.01, 0.04)])
def test_curl_radius(radius, pitch):
    g = grow(plane(), 50, "curly", points_per_strand=96, seed=2, curl_radius=radius,
             curl_pitch=pitch, length=0.3, curl_start=0.01, **UPRIGHT)
    P = g.as_padded().astype(np.float64)
    for strand in P[:10]:
        y0 = strand[0, 1]
        part = strand[strand[:, 1] > y0 + 0.02]  # past the fade-in
        # the axis is +Y (the plane normal): fit a circle in XZ
        _, r = fit_circle(part[:, [0, 2]])
        assert abs(r - radius) <= 0.05 * radius
        # the axis runs through the root
        centre, _ = fit_circle(part[:, [0, 2]])
        assert np.linalg.norm(centre - strand[0, [0, 2]]) < 0.05 * radius
        # pitch: rise per turn
        ang = np.unwrap(np.arctan2(part[:, 2] - centre[1], part[:, 0] - centre[0]))
        rise = np.polyfit(ang, part[:, 1], 1)[0] * 2 * np.pi
        assert abs(abs(rise) - pitch) <= 0.05 * pitch


def test_curly_length_is_arc_length():
    g = grow(plane(), 20, "curly", points_per_strand=200, seed=2, curl_radius=0.006,
             curl_pitch=0.02, length=0.25, curl_start=1e-3, **UPRIGHT)
    np.testing.assert_allclose(g.strand_lengths(), 0.25, rtol=0.03)


def test_wavy_amplitude():
    amp, wl = 0.01, 0.05
    g = grow(plane(), 30, "wavy", points_per_strand=161, seed=3, wave_amplitude=amp,
             wave_length=wl, length=0.2, curl_start=0.005, **UPRIGHT)
    P = g.as_padded().astype(np.float64)
    for strand in P:
        lateral = np.linalg.norm(strand[:, [0, 2]] - strand[0, [0, 2]], axis=1)
        far = strand[:, 1] > strand[0, 1] + 0.02
        assert abs(lateral[far].max() - amp) <= 0.03 * amp
        # planar: the sideways offsets are all along one line through the root
        off = strand[far][:, [0, 2]] - strand[0, [0, 2]]
        sv = np.linalg.svd(off, compute_uv=False)
        assert sv[1] < 1e-3 * sv[0]


def test_straight_upright_strands_follow_the_normal():
    g = grow(plane(), 40, "straight", points_per_strand=8, seed=1, length=0.1, **UPRIGHT)
    P = g.as_padded().astype(np.float64)
    np.testing.assert_allclose(P[:, :, [0, 2]], np.broadcast_to(P[:, :1, [0, 2]], P[:, :, [0, 2]].shape), atol=1e-6)
    np.testing.assert_allclose(g.strand_lengths(), 0.1, rtol=1e-5)


def test_droop_bends_down():
    # on a vertical wall facing +Z, droop turns hair toward -Y
    m = plane().transformed(np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]]))
    assert np.allclose(m.face_normals(), [0, 0, 1])
    stiff = grow(m, 30, "straight", 16, seed=1, length=0.1, **UPRIGHT)
    drooped = grow(m, 30, "straight", 16, seed=1, length=0.1, **{**UPRIGHT, "droop": 1.0})
    dy_stiff = (stiff.tips - stiff.roots)[:, 1]
    dy_droop = (drooped.tips - drooped.roots)[:, 1]
    assert np.abs(dy_stiff).max() < 1e-6
    assert np.all(dy_droop < -0.05)
    # the first segment still leaves the surface
    P = drooped.as_padded()
    assert np.all(P[:, 1, 2] > P[:, 0, 2])


def test_clumping_pulls_tips_together():
    base = dict(UPRIGHT, clump_radius=0.02, clump_taper=1.0)
    free = grow(plane(), 400, "wavy", 16, seed=4, **base)
    clumped = grow(plane(), 400, "wavy", 16, seed=4, **{**base, "clump_strength": 0.8})
    leader = clumped.strand_attributes["clump"]
    assert 1 < len(np.unique(leader)) < 400
    tip_spread_free = np.linalg.norm(free.tips - free.tips[leader], axis=1).mean()
    tip_spread = np.linalg.norm(clumped.tips - clumped.tips[leader], axis=1).mean()
    assert tip_spread == pytest.approx(0.2 * tip_spread_free, rel=1e-3)
    np.testing.assert_allclose(clumped.roots, free.roots)  # roots never move


def test_hair_stays_outside_the_head(head):
    # the default head's mesh lies on the zero set of head_sdf (tested in test_grooming_head),
    # so the analytic field is an independent inside test; 0.5 mm covers the facets' sag
    from mane.grooming.head import head_sdf

    for style in ("straight", "curly"):
        g = grow(head, 1500, style, 16, seed=5)
        pts = g.as_padded()[:, 1:].reshape(-1, 3).astype(np.float64)
        inside = head_sdf(pts) < -5e-4
        assert inside.mean() < 0.01, style


def test_grow_on_the_default_head(head):
    t = time.perf_counter()
    g = grow(head, 2000, "curly", 32, seed=1)
    elapsed = time.perf_counter() - t
    assert g.num_strands == 2000 and g.uniform_count == 32
    assert elapsed < 30
    # roots on the painted scalp
    w = head.colors[:, 0].astype(np.float64)[head.faces[g.strand_attributes["face_index"]]]
    assert np.all((w * g.strand_attributes["root_barycentric"]).sum(axis=1) >= 0.5 - 1e-6)
    # widths taper from 70 micrometres
    W = g.widths.reshape(2000, 32)
    np.testing.assert_allclose(W[:, 0], 70e-6, rtol=1e-6)
    assert np.all(np.diff(W, axis=1) <= 0) and np.all(W[:, -1] < W[:, 0])
    assert g.colors is not None and g.colors.shape == (64000, 3)
    assert g.metadata["style"]["kind"] == "curly"


def test_deterministic_by_seed(head):
    a = grow(head, 300, "wavy", 12, seed=8)
    b = grow(head, 300, "wavy", 12, seed=8)
    c = grow(head, 300, "wavy", 12, seed=9)
    assert a.equals(b)
    assert not np.array_equal(a.points, c.points)


def test_presets_and_settings():
    assert {"straight", "wavy", "curly"} <= set(PRESETS)
    s = style_settings("curly", curl_radius=0.01)
    assert s.kind == "curly" and s.curl_radius == 0.01
    with pytest.raises(ManeError, match="unknown style"):
        style_settings("mohawk")
    with pytest.raises(ManeError, match="length"):
        style_settings("straight", length=-1.0)
    with pytest.raises(ManeError, match="clump_strength"):
        StyleSettings(clump_strength=2.0).validate()
    with pytest.raises(ManeError, match="kind"):
        StyleSettings(kind="frizzy").validate()


def test_bad_inputs(head):
    with pytest.raises(ManeError, match="positive"):
        grow(head, 0)
    with pytest.raises(ManeError, match="points per strand"):
        grow(head, 10, points_per_strand=1)
    with pytest.raises(ManeError, match="no faces"):
        grow(head, 10, region=np.zeros(len(head.faces), bool))
    with pytest.raises(TypeError):
        grow(head, 10, num_guides=5)
