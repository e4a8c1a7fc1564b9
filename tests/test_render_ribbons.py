"""Ribbons from the geometry shader: width and taper, perpendicular to the tangent, facing
the camera; coverage alpha for strands thinner than the pixel minimum."""
from __future__ import annotations

import numpy as np
import pytest

from mane.groom import Groom
from mane.render import Camera, Renderer, RenderSettings
from mane.render.capture import capture_segments

pytestmark = pytest.mark.gpu


def groom() -> Groom:
    t = np.linspace(0, 1, 6)
    return Groom.from_strands([np.c_[0.05 * np.sin(3 * t + g), -0.25 * t, 0.05 * np.cos(2 * t + g)] + [0.06 * g, 0, 0]
                               for g in range(3)])


CAM = Camera(eye=(0.3, 0.1, 0.8), target=(0.05, -0.12, 0.0), fov_y=30.0, near=0.05, far=5.0)


def capture(gl, **kw):
    base = dict(size=(160, 120), msaa=1, strands_per_guide=4, segments=10, width=0.002, width_tip=0.4,
                min_pixel_width=0.0)
    base.update(kw)
    r = Renderer(RenderSettings(**base), ctx=gl, profile=False)
    try:
        r.set_strands(groom())
        view = r.camera_view(CAM)
        return capture_segments(r, CAM), view
    finally:
        r.release()


def test_ribbon_width_and_taper(gl):
    seg, _ = capture(gl)
    for end, s in ((0, seg["s0"]), (1, seg["s1"])):
        c = seg["corners"][:, 2 * end:2 * end + 2]
        width = np.linalg.norm(c[:, 1] - c[:, 0], axis=1)
        np.testing.assert_allclose(width, 0.002 * (1 + (0.4 - 1) * s), rtol=1e-4)
        # the ribbon is centred on the curve
        p = seg["p0"] if end == 0 else seg["p1"]
        np.testing.assert_allclose(0.5 * (c[:, 0] + c[:, 1]), p, atol=1e-7)


def test_ribbon_is_perpendicular_to_the_tangent_and_faces_the_camera(gl):
    seg, _ = capture(gl)
    eye = np.asarray(CAM.eye)
    for end in (0, 1):
        c = seg["corners"][:, 2 * end:2 * end + 2]
        side = c[:, 1] - c[:, 0]
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        p = seg["p0"] if end == 0 else seg["p1"]
        t = seg["t0"] if end == 0 else seg["t1"]
        v = eye - p
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        assert np.abs(np.einsum("ij,ij->i", side, t)).max() < 1e-4   # float32 corners 2 mm apart
        assert np.abs(np.einsum("ij,ij->i", side, v)).max() < 1e-4
        # the ribbon's normal (in the plane of T and V) is as close to V as such a strip can be
        n = np.cross(side, t)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        cos_tv = np.einsum("ij,ij->i", t, v)
        np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", n, v)), np.sqrt(1 - cos_tv**2), atol=1e-4)


def test_subpixel_strands_get_coverage_alpha(gl):
    seg, view = capture(gl, width=0.0001, width_tip=1.0, min_pixel_width=1.0)
    depth = (seg["p0"] - np.asarray(CAM.eye)) @ CAM.forward
    pixel = view.pixel_size * depth
    width = np.linalg.norm(seg["corners"][:, 1] - seg["corners"][:, 0], axis=1)
    np.testing.assert_allclose(width, np.maximum(pixel, 0.0001), rtol=1e-4)     # widened to a pixel
    np.testing.assert_allclose(seg["alpha0"], np.minimum(1.0, 0.0001 / pixel), rtol=1e-4)
    assert seg["alpha0"].max() < 0.5
