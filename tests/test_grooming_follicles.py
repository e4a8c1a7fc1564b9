"""Follicle sampling: on the surface, uniform per area, Poisson-disk spacing, regions, seeds."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.stats import chisquare

from mane.errors import ManeError
from mane.grooming.follicles import (AbovePlane, AllOf, NormalCone, VertexColorRegion,
                                     frame_from_normal, sample_follicles)
from mane.grooming.head import default_head
from mane.mesh import Mesh


@pytest.fixture(scope="module")
def head():
    return default_head()


def uneven_mesh():
    """A unit-ish sphere with very uneven triangle areas (its vertices squeezed toward a pole)."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=3)
    v = np.asarray(s.vertices, dtype=np.float64)
    v[:, 1] = np.sign(v[:, 1]) * np.abs(v[:, 1]) ** 0.5  # stretch: areas vary several-fold
    return Mesh(v * 0.1, s.faces)


def point_triangle_distance(p, tri):
    """Exact distance from points (N,3) to their triangles (N,3,3), via trimesh's closest point."""
    from trimesh.triangles import closest_point

    return np.linalg.norm(closest_point(tri, p) - p, axis=1)


def test_roots_lie_on_the_surface(head):
    f = sample_follicles(head, 2000, seed=3)
    tri = head.triangles[f.face_index]
    d = point_triangle_distance(f.positions, tri)
    assert d.max() <= 1e-5 * head.diagonal()
    assert np.all(f.barycentrics >= 0) and np.allclose(f.barycentrics.sum(axis=1), 1.0)
    # and against the whole mesh (brute force over every triangle), on a sample
    all_tri = head.triangles
    for p in f.positions[:25]:
        d_all = point_triangle_distance(np.broadcast_to(p, (len(all_tri), 3)), all_tri)
        assert d_all.min() <= 1e-5 * head.diagonal()


def test_blue_noise_roots_lie_on_the_surface(head):
    f = sample_follicles(head, 3000, region=VertexColorRegion(), method="blue_noise", seed=5)
    d = point_triangle_distance(f.positions, head.triangles[f.face_index])
    assert d.max() <= 1e-5 * head.diagonal()


def test_density_is_uniform_per_area():
    mesh = uneven_mesh()
    areas = mesh.face_areas()
    assert areas.max() / areas.min() > 3
    n = 200_000
    f = sample_follicles(mesh, n, seed=11)
    counts = np.bincount(f.face_index, minlength=len(areas))
    expected = n * areas / areas.sum()
    assert chisquare(counts, expected).pvalue > 0.001


def test_density_uniform_within_a_triangle():
    # one right triangle: the fraction below x + z = 1/2 (a quarter of the area) gets a quarter
    mesh = Mesh([[0, 0, 0], [0, 0, 1], [1, 0, 0]], [[0, 1, 2]])
    f = sample_follicles(mesh, 40_000, seed=2)
    x, z = f.positions[:, 0], f.positions[:, 2]
    inner = (x + z < 0.5).sum()
    bins = np.array([inner, len(x) - inner])
    assert chisquare(bins, np.array([0.25, 0.75]) * len(x)).pvalue > 0.001


def test_poisson_disk_keeps_a_minimum_distance(head):
    f = sample_follicles(head, 5000, region=VertexColorRegion(), method="blue_noise", seed=1)
    assert len(f) == 5000 and f.min_distance > 0
    d, _ = cKDTree(f.positions).query(f.positions, k=2)
    assert d[:, 1].min() >= f.min_distance * (1 - 1e-9)
    # and it is blue: the nearest-neighbour distance is far more even than for uniform samples
    u = sample_follicles(head, 5000, region=VertexColorRegion(), seed=1)
    du, _ = cKDTree(u.positions).query(u.positions, k=2)
    assert d[:, 1].std() / d[:, 1].mean() < 0.5 * du[:, 1].std() / du[:, 1].mean()


def test_explicit_min_distance(head):
    f = sample_follicles(head, 500, region=VertexColorRegion(), method="blue_noise",
                         min_distance=0.004, seed=1)
    d, _ = cKDTree(f.positions).query(f.positions, k=2)
    assert d[:, 1].min() >= 0.004
    with pytest.raises(ManeError, match="cannot fit"):
        sample_follicles(head, 50_000, region=VertexColorRegion(), method="blue_noise",
                         min_distance=0.01, seed=1)


def test_vertex_colour_region(head):
    f = sample_follicles(head, 3000, region=VertexColorRegion(0, 0.5), seed=4)
    w = head.colors[:, 0].astype(np.float64)[head.faces[f.face_index]]
    assert np.all((w * f.barycentrics).sum(axis=1) >= 0.5)


def test_face_set_region(head):
    faces = np.arange(0, len(head.faces), 7)
    f = sample_follicles(head, 1000, region=faces, seed=4)
    assert np.isin(f.face_index, faces).all()
    mask = np.zeros(len(head.faces), bool)
    mask[faces] = True
    g = sample_follicles(head, 1000, region=mask, seed=4)
    assert mask[g.face_index].all()


def test_predicate_regions(head):
    cone = NormalCone((0.0, 1.0, 0.0), np.radians(30))
    f = sample_follicles(head, 1000, region=cone, seed=4)
    assert np.all(f.normals[:, 1] >= np.cos(np.radians(30)) - 1e-12)
    plane = AbovePlane((0.0, 0.05, 0.0), (0.0, 1.0, 0.0))
    g = sample_follicles(head, 1000, region=plane, seed=4)
    assert np.all(g.positions[:, 1] >= 0.05)
    both = AllOf((cone, AbovePlane((0, 0, 0), (0, 0, -1))))
    h = sample_follicles(head, 500, region=both, seed=4)
    assert np.all(h.positions[:, 2] <= 0) and np.all(h.normals[:, 1] >= np.cos(np.radians(30)) - 1e-12)
    q = sample_follicles(head, 500, region=lambda p, n: p[:, 0] > 0.02, seed=4)
    assert np.all(q.positions[:, 0] > 0.02)


def test_deterministic_by_seed(head):
    for method in ("uniform", "blue_noise"):
        a = sample_follicles(head, 800, region=VertexColorRegion(), method=method, seed=9)
        b = sample_follicles(head, 800, region=VertexColorRegion(), method=method, seed=9)
        c = sample_follicles(head, 800, region=VertexColorRegion(), method=method, seed=10)
        np.testing.assert_array_equal(a.positions, b.positions)
        assert not np.array_equal(a.positions, c.positions)


def test_frames_are_orthonormal_and_right_handed(head):
    f = sample_follicles(head, 2000, seed=4)
    F = f.frames
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", F, F), np.broadcast_to(np.eye(3), F.shape), atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(F), 1.0, atol=1e-9)
    t, b = frame_from_normal(np.array([[0.0, 1.0, 0.0]]))
    np.testing.assert_allclose(t, [[0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(b, [[1, 0, 0]], atol=1e-12)
    # smooth: nearby normals give nearby tangents
    n = np.array([[0.6, 0.0, 0.8], [0.6, 0.001, 0.8]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t2, _ = frame_from_normal(n)
    assert np.linalg.norm(t2[0] - t2[1]) < 0.01


def test_bad_inputs(head):
    with pytest.raises(ManeError, match="positive"):
        sample_follicles(head, 0)
    with pytest.raises(ManeError, match="method"):
        sample_follicles(head, 10, method="grid")
    with pytest.raises(ManeError, match="no faces"):
        sample_follicles(head, 10, region=np.zeros(len(head.faces), bool))
    with pytest.raises(ManeError, match="no faces"):
        sample_follicles(head, 10, region=VertexColorRegion(1, 2.0))
    with pytest.raises(ManeError, match="shape"):
        sample_follicles(head, 10, region=np.ones(3, bool))
    bare = Mesh(head.vertices, head.faces)
    with pytest.raises(ManeError, match="no vertex colours"):
        sample_follicles(bare, 10, region=VertexColorRegion())
    with pytest.raises(ManeError, match="accepts almost no"):
        sample_follicles(head, 10, region=AbovePlane((0, 5.0, 0), (0, 1, 0)))
