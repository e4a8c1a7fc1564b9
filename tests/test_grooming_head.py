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
