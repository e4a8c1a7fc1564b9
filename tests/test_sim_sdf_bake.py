"""The NumPy-only SDF bake (mane.sim.sdf_bake) against a brute-force exact distance and against
the earlier bake (tests/sdf_bake_v1.py: k-d tree and SciPy distance transform), without a GL
context: the band within 3 h is the exact distance (1e-6 m: float32 of the metres), which the
earlier bake matched within its 2 h band wherever it found the nearest triangle and never
undercut; the sign is the same method and must agree node for node; farther nodes are never too
small and within the earlier bake's error of the exact distance."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import sdf_bake_v1 as v1
from mane.bench.sim_bench import head_mesh
from mane.errors import GroomError, UsageError
from mane.sim import sdf_bake
from mane.sim.sdf_bake import bake_sdf, nearest_marked, triangle_distance2, triangle_frames

TOL = 1e-6   # metres: float32 rounding of values below 0.2 m is < 1e-8


def exact_distance(points, tris, chunk=256):
    """Brute force: the least Ericson point-triangle distance over every triangle."""
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        p = points[s:s + chunk]
        P = np.repeat(p, len(tris), axis=0)
        cp = v1.closest_points_on_triangles(P, *(np.tile(tris[:, c], (len(p), 1)) for c in range(3)))
        out[s:s + chunk] = np.linalg.norm(P - cp, axis=1).reshape(len(p), len(tris)).min(axis=1)
    return out


def nodes(lo, h, shape, flat=None):
    ijk = np.indices(shape).reshape(3, -1).T if flat is None else np.stack(np.unravel_index(flat, shape), 1)
    return lo + ijk * h


def test_triangle_distance_matches_ericson():
    rng = np.random.default_rng(3)
    tris = rng.normal(size=(400, 3, 3))
    tris[:20, 2] = tris[:20, 0] + 0.5 * (tris[:20, 1] - tris[:20, 0])      # degenerate: a segment
    tris[20:30, 1] = tris[20:30, 2] = tris[20:30, 0]                        # degenerate: a point
    p = rng.normal(size=(400, 3)) * 2
    R, B, Cx, Cy = triangle_frames(tris)
    q = p - tris[:, 0]
    u, v, w = ((R[:, a] * q).sum(axis=1) for a in range(3))
    d2, cu, cv = triangle_distance2(u, v, w, B, Cx, Cy, closest=True)
    cp = v1.closest_points_on_triangles(p, tris[:, 0], tris[:, 1], tris[:, 2])
    np.testing.assert_allclose(np.sqrt(d2), np.linalg.norm(p - cp, axis=1), rtol=0, atol=1e-12)
    got = tris[:, 0] + cu[:, None] * R[:, 0] + cv[:, None] * R[:, 1]
    np.testing.assert_allclose(got, cp, atol=1e-9)


def test_nearest_marked_is_the_brute_force_nearest():
    rng = np.random.default_rng(4)
    shape = (9, 12, 7)
    mark = rng.random(shape) < 0.03
    mark[0, 0, 0] = True
    got = nearest_marked(mark).reshape(-1)
    g = np.indices(shape).reshape(3, -1).T
    marked = np.nonzero(mark.reshape(-1))[0]
    d2 = ((g[:, None] - g[marked][None]) ** 2).sum(axis=2)
    want = d2.min(axis=1)
    np.testing.assert_array_equal(((g - g[got]) ** 2).sum(axis=1), want)   # ties may pick either
    assert mark.reshape(-1)[got].all()


@pytest.mark.parametrize("mesh", ["icosphere", "box", "torus"])
def test_small_mesh_against_brute_force_and_the_earlier_bake(mesh):
    m = {"icosphere": lambda: trimesh.creation.icosphere(subdivisions=2, radius=0.3),
         "box": lambda: trimesh.creation.box(extents=(0.3, 0.5, 0.2)),
         "torus": lambda: trimesh.creation.torus(0.3, 0.1, major_sections=24, minor_sections=12)}[mesh]()
    values, lo, h = bake_sdf(m.vertices, m.faces, 24, 0.08)
    old, lo_old, h_old = v1.bake_sdf(m.vertices, m.faces, 24, 0.08)
    assert values.shape == old.shape and values.dtype == np.float32
    np.testing.assert_array_equal(lo, lo_old)
    assert h == h_old
    tris = np.asarray(m.vertices, np.float64)[np.asarray(m.faces)]
    exact = exact_distance(nodes(lo, h, values.shape), tris)
    got = np.abs(values.reshape(-1).astype(np.float64))
    exact_band = exact <= sdf_bake.BAND * h
    np.testing.assert_allclose(got[exact_band], exact[exact_band], rtol=0, atol=TOL)
    assert (got >= exact - TOL).all()                                     # never too small
    o = np.abs(old.reshape(-1).astype(np.float64))
    band = exact <= 2 * h                                                 # the earlier bake's band
    assert (got[band] <= o[band] + TOL).all()                             # the earlier never undercut
    assert (np.abs(got[band] - o[band]) <= TOL).mean() > 0.97
    assert (got - exact).max() <= (o - exact).max() + 0.1 * h             # far: the earlier's error
    np.testing.assert_array_equal(values < 0, old < 0)                    # the same sign test


@pytest.fixture(scope="module")
def bench_head():
    m = head_mesh()
    new = bake_sdf(m.vertices, m.faces, 64, 0.02)
    old = v1.bake_sdf(m.vertices, m.faces, 64, 0.02)
    return m, new, old


def test_bench_head_band_agrees_with_the_earlier_bake(bench_head):
    """The sim bench's head at the full solver's SDF (64^3, 0.02 m): the same grid and sign;
    in the band the earlier bake's value wherever it was exact (99.7 % of the band nodes), and
    at the rest the exact distance (brute force), below the earlier one."""
    m, (values, lo, h), (old, lo_old, h_old) = bench_head
    np.testing.assert_array_equal(lo, lo_old)
    assert h == h_old and values.shape == old.shape
    np.testing.assert_array_equal(values < 0, old < 0)
    got, o = np.abs(values.reshape(-1)).astype(np.float64), np.abs(old.reshape(-1)).astype(np.float64)
    band = np.nonzero(np.minimum(got, o) <= 2 * h)[0]
    same = np.abs(got[band] - o[band]) <= TOL
    assert same.mean() > 0.99
    assert (got[band] <= o[band] + TOL).all()
    differ = band[~same]
    tris = np.asarray(m.vertices, np.float64)[np.asarray(m.faces)]
    np.testing.assert_allclose(got[differ], exact_distance(nodes(lo, h, values.shape, differ), tris),
                               rtol=0, atol=TOL)


def test_bench_head_far_field_is_an_upper_bound_near_the_exact(bench_head):
    m, (values, lo, h), (old, _, _) = bench_head
    got = np.abs(values.reshape(-1)).astype(np.float64)
    rng = np.random.default_rng(5)
    pick = rng.choice(np.nonzero(got > 2 * h)[0], 600, replace=False)
    tris = np.asarray(m.vertices, np.float64)[np.asarray(m.faces)]
    exact = exact_distance(nodes(lo, h, values.shape, pick), tris)
    assert (got[pick] >= exact - TOL).all()
    assert (got[pick] - exact).max() < 0.4 * h
    o = np.abs(old.reshape(-1)[pick]).astype(np.float64)
    assert abs((got[pick] - exact).mean() - (o - exact).mean()) < 0.02 * h


def test_bad_inputs_have_one_line_errors():
    box = trimesh.creation.box()
    with pytest.raises(GroomError, match="without faces"):
        bake_sdf(box.vertices, np.zeros((0, 3), int))
    with pytest.raises(GroomError, match="no extent"):
        bake_sdf(np.zeros((3, 3)), [[0, 1, 2]])
    with pytest.raises(UsageError, match="resolution"):
        bake_sdf(box.vertices, box.faces, resolution=600)


def test_too_many_pairs_is_a_usage_error(monkeypatch):
    box = trimesh.creation.box()
    monkeypatch.setattr(sdf_bake, "MAX_PAIRS", 100)
    with pytest.raises(UsageError, match="triangle-node pairs"):
        bake_sdf(box.vertices, box.faces, resolution=16)


def test_chunking_does_not_change_the_field(monkeypatch):
    """The band's windows and the distance transform's lines in many small chunks (as a big mesh
    or grid would take them) give the same field: the same sign, the same distances to float32
    round-off (a different matrix size may round a local coordinate differently and pick another
    of two triangles equally near in float32)."""
    m = trimesh.creation.torus(0.3, 0.1, major_sections=24, minor_sections=12)
    want = bake_sdf(m.vertices, m.faces, 20, 0.05)[0]
    monkeypatch.setattr(sdf_bake, "_CHUNK_PAIRS", 300)
    monkeypatch.setattr(sdf_bake, "_CHUNK_LINES", 500)
    got = bake_sdf(m.vertices, m.faces, 20, 0.05)[0]
    np.testing.assert_array_equal(got < 0, want < 0)
    np.testing.assert_allclose(got, want, rtol=0, atol=TOL)
