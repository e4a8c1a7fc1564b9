"""The procedural default head: closed, outward, human-sized, with a painted scalp."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import GroomError
from mane.grooming.head import default_head, head_sdf, scalp_faces, scalp_mask, scalp_weight
from mane.mesh import Mesh


@pytest.fixture(scope="module")
def head():
    return default_head()


def test_watertight_and_counts(head):
    tm = head.to_trimesh()
    assert tm.is_watertight
    assert tm.is_winding_consistent
    assert 10_000 <= len(head.faces) <= 40_000


def test_outward_normals(head):
    tri = head.triangles
    signed_volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
    assert signed_volume > 0
    # every face normal agrees with the field's gradient (points outward)
    c = tri.mean(axis=1)
    h = 1e-5
    g = np.stack([(head_sdf(c + h * e) - head_sdf(c - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
    agree = (head.face_normals() * g).sum(axis=1) > 0
    assert agree.mean() > 0.999


def test_vertices_lie_on_the_field_zero_set(head):
    assert np.abs(head_sdf(head.vertices.astype(np.float64))).max() < 2e-4


def test_dimensions_are_human(head):
    v = head.vertices.astype(np.float64)
    crown = v[:, 1].max()
    face = v[(np.abs(v[:, 0]) < 0.015) & (v[:, 2] > 0.05) & (v[:, 1] > -0.16)]  # face, not the neck
    chin = face[:, 1].min()
    assert 0.20 <= crown - chin <= 0.26
    lo, hi = head.bbox()
    assert 0.35 <= hi[0] - lo[0] <= 0.55        # shoulders
    skull = v[v[:, 1] > 0.0]
    assert 0.13 <= np.ptp(skull[:, 0]) <= 0.19  # head breadth (ears excluded above y = 0 mostly)
    assert 0.17 <= np.ptp(skull[:, 2]) <= 0.23  # head length, glabella to back
    assert v[np.argmax(v[:, 2]), 1] < 0.0       # the nose tip is the frontmost point, below the eyes


def test_deterministic():
    a, b = default_head(subdivisions=3, relax_rounds=3), default_head(subdivisions=3, relax_rounds=3)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)


def test_scalp_painted_with_a_hairline(head):
    w = head.colors[:, 0]
    assert w.min() >= 0.0 and w.max() <= 1.0
    np.testing.assert_allclose(head.vertex_attributes["scalp"], w)
    pts = np.array([
        [0.0, 0.11, 0.0],      # crown
        [0.0, 0.03, -0.10],    # back of the head
        [0.0, 0.09, 0.05],     # above the forehead hairline
        [0.0, 0.0, 0.09],      # between the eyes
        [0.0, -0.10, 0.07],    # chin
        [0.0, -0.30, 0.09],    # chest
        [0.085, -0.01, -0.015],  # the ear
    ])
    ws = scalp_weight(pts)
    assert ws[0] == 1 and ws[1] == 1 and ws[2] == 1
    assert ws[3] == 0 and ws[4] == 0 and ws[5] == 0 and ws[6] < 0.5
    mask = scalp_mask(head)
    frac = mask.mean()
    assert 0.05 < frac < 0.6
    fm = scalp_faces(head)
    assert fm.shape == (len(head.faces),) and fm.any()


def test_scalp_mask_needs_colours():
    m = Mesh(np.eye(3), [[0, 1, 2]])
    with pytest.raises(GroomError, match="no vertex colours"):
        scalp_mask(m)


# ---------------------------------------------------------------- from anthropometry and topology


def test_every_edge_has_exactly_two_faces(head):
    """Closed 2-manifold by counting: each undirected edge is used twice, once each way."""
    f = head.faces.astype(np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)  # no directed edge twice
    undirected, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    assert np.all(counts == 2)
    # Euler characteristic V - E + F of a sphere-like surface (no handles)
    assert len(head.vertices) - len(undirected) + len(f) == 2


def test_left_right_symmetric(head):
    """The mirror image of every vertex lies on the surface (within a fraction of an edge)."""
    from scipy.spatial import cKDTree

    v = head.vertices.astype(np.float64)
    mirrored = v * np.array([-1.0, 1.0, 1.0])
    d, _ = cKDTree(v).query(mirrored)
    edge = np.linalg.norm(v[head.faces[:, 0]] - v[head.faces[:, 1]], axis=1)
    assert np.median(d) < 0.5 * np.median(edge)
    assert np.abs(head_sdf(mirrored)).max() < 3e-4


def test_anthropometric_dimensions(head):
    """Adult ranges (e.g. ANSUR II / Farkas): head breadth 14-16.5 cm, head length (glabella to
    back) 18-21.5 cm, menton to vertex 21-25 cm, forehead (brow to hairline) 4-7 cm."""
    v = head.vertices.astype(np.float64)
    skull = v[v[:, 1] > 0.02]  # above the ears
    assert 0.14 <= np.ptp(skull[:, 0]) <= 0.165
    assert 0.18 <= np.ptp(skull[:, 2]) <= 0.215
    face = v[(np.abs(v[:, 0]) < 0.015) & (v[:, 2] > 0.04) & (v[:, 1] > -0.16)]
    assert 0.21 <= v[:, 1].max() - face[:, 1].min() <= 0.25
    w = head.colors[:, 0]
    midline_front = (np.abs(v[:, 0]) < 0.01) & (v[:, 2] > 0.04) & (v[:, 1] > 0.0)
    hairline = v[midline_front & (w >= 0.5), 1].min()
    brow = v[(np.abs(v[:, 0] - 0.03) < 0.01) & (v[:, 1] > 0.0) & (v[:, 1] < 0.045)]
    brow_y = brow[np.argmax(brow[:, 2]), 1]   # the most forward point above the eye
    assert 0.04 <= hairline - brow_y <= 0.07


def test_scalp_area_is_a_human_scalp(head):
    """The hair-bearing scalp of an adult is about 600 cm² (0.05-0.075 m²)."""
    area = head.face_areas()[scalp_faces(head)].sum()
    assert 0.05 <= area <= 0.075


def test_face_features_stand_out():
    """Seen along rays from the front: the nose tip ahead of the lips, the lips ahead of the
    chin, the eyes set back behind the brow ridge (the surface the mesh lies on)."""
    zs = np.linspace(0.2, 0.0, 4001)

    def z(x, y):
        f = head_sdf(np.stack([np.full_like(zs, x), np.full_like(zs, y), zs], axis=1))
        return zs[np.argmax(f < 0)]

    nose, lips, chin = z(0.0, -0.030), z(0.0, -0.060), z(0.0, -0.100)
    assert nose > lips + 0.01 and lips > chin + 0.01
    assert z(0.032, 0.0) < z(0.032, 0.024) - 0.003
