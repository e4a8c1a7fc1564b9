"""The pinhole camera's look-at view (render/camera.py) from first principles: a rigid motion
(orthonormal rows, determinant +1) taking the eye to the origin and the target onto -Z at its
distance, the up vector in the view's Y-Z plane on the +Y side; a fallback up when up is along
the view; a clear error for a zero direction."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from mane.errors import UsageError
from mane.render.camera import Camera, look_at

coord = st.floats(-50.0, 50.0, allow_nan=False, width=64)
vec = st.tuples(coord, coord, coord)


@settings(max_examples=300, deadline=None)
@given(eye=vec, target=vec, up=vec)
def test_look_at_is_the_rigid_motion_to_the_eye(eye, target, up):
    e, t, u = (np.asarray(x, float) for x in (eye, target, up))
    d = np.linalg.norm(t - e)
    if d < 1e-3 or np.linalg.norm(u) < 1e-3:
        return
    V = look_at(eye, target, up)
    R = V[:3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(V[3], [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(V @ np.r_[e, 1.0], [0.0, 0.0, 0.0, 1.0], atol=1e-9 * (1 + np.abs(e).max()))
    np.testing.assert_allclose(V @ np.r_[t, 1.0], [0.0, 0.0, -d, 1.0], atol=1e-9 * (1 + np.abs(e).max() + d))
    f = (t - e) / d
    un = u / np.linalg.norm(u)
    if abs(f @ un) <= 0.999:   # up kept: it lies in the view's Y-Z plane, on the +Y side
        ru = R @ un
        assert abs(ru[0]) < 1e-9 and ru[1] > 0.0
    else:                      # up along the view: another up, still a rigid motion (checked above)
        assert np.all(np.isfinite(V))


def test_look_at_known_values_and_errors():
    V = look_at((0.0, 0.0, 2.0), (0.0, 0.0, 0.0))   # from +Z toward the origin: a translation
    np.testing.assert_allclose(V, [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -2], [0, 0, 0, 1]], atol=1e-15)
    V = look_at((3.0, 0.0, 0.0), (0.0, 0.0, 0.0))   # from +X: the view's -Z is world -X, its X world -Z
    np.testing.assert_allclose(V[:3, :3], [[0, 0, -1], [0, 1, 0], [1, 0, 0]], atol=1e-15)
    with pytest.raises(UsageError, match="zero vector"):
        look_at((1.0, 1.0, 1.0), (1.0, 1.0, 1.0))
    with pytest.raises(UsageError, match="zero vector"):
        look_at((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 0.0))
    cam = Camera(eye=(1.0, 2.0, 3.0), target=(1.0, 2.0, -1.0))
    np.testing.assert_allclose(cam.forward, [0.0, 0.0, -1.0])
    np.testing.assert_allclose(cam.view()[2, :3], -cam.forward)


def test_a_camera_keeps_its_vectors_as_tuples():
    """Lists and NumPy arrays become tuples of floats, so cameras compare and hash by value
    (the renderer keeps a view while its camera is the same)."""
    a = Camera(eye=np.array([0.1, 0.2, 1.0]), target=[0, 0, 0], up=np.array([0, 1, 0]))
    b = Camera(eye=(0.1, 0.2, 1.0), target=(0.0, 0.0, 0.0))
    assert a.eye == (0.1, 0.2, 1.0) and type(a.target) is tuple and a == b and hash(a) == hash(b)
    with pytest.raises(UsageError, match="eye"):
        Camera(eye=["x", 0, 1])
