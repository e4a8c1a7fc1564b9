"""The HDR depth cleared over the head's screen box of this frame and the last (render/screen_box.py):
the box against the projected mesh, and every frame of a moving camera, head and no head the
picture a fresh renderer draws."""
from __future__ import annotations

import moderngl
import numpy as np
import pytest

from mane.grooming.scene import default_groom, default_head
from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera, look_at, perspective
from mane.render.screen_box import FULL, screen_box, union


def _pixels(view_proj, pts, model, size):
    c = np.c_[pts, np.ones(len(pts))] @ (view_proj @ model).T
    ndc = c[:, :2] / c[:, 3:]
    return (ndc + 1.0) * 0.5 * np.asarray(size)


@pytest.mark.parametrize("seed", range(6))
def test_the_box_holds_every_projected_point_and_little_more(seed):
    rng = np.random.default_rng(seed)
    size = (320, 200)
    pts = rng.normal(0.0, 0.1, (500, 3))
    lo, hi = pts.min(0), pts.max(0)
    model = np.eye(4)
    model[:3, 3] = rng.uniform(-0.1, 0.1, 3)
    eye = rng.normal(0.0, 1.0, 3)
    eye *= rng.uniform(0.8, 1.5) / np.linalg.norm(eye)
    vp = perspective(40.0, size[0] / size[1], 0.05, 10.0) @ look_at(eye, (0.0, 0.0, 0.0))
    box = screen_box(vp, lo, hi, model, size)
    px = _pixels(vp, pts, model, size)
    inside = (px[:, 0] >= 0) & (px[:, 0] < size[0]) & (px[:, 1] >= 0) & (px[:, 1] < size[1])
    assert box not in (None, FULL)
    x, y, w, h = box
    assert np.all(px[inside, 0] >= x) and np.all(px[inside, 0] <= x + w)
    assert np.all(px[inside, 1] >= y) and np.all(px[inside, 1] <= y + h)
    corners = _pixels(vp, np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1])
                                    for c in (lo[2], hi[2])]), model, size)
    cx0, cy0 = np.clip(corners.min(0), 0, size), np.clip(corners.max(0), 0, size)
    assert x >= cx0[0] - 2 and x + w <= cy0[0] + 2 and y >= cx0[1] - 2 and y + h <= cy0[1] + 2


def test_behind_the_eye_off_screen_and_unions():
    vp = perspective(40.0, 1.0, 0.05, 10.0) @ look_at((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    assert screen_box(vp, (-0.1, -0.1, 0.9), (0.1, 0.1, 1.1), np.eye(4), (64, 64)) == FULL   # around the eye
    assert screen_box(vp, (5.0, 5.0, -0.1), (5.1, 5.1, 0.1), np.eye(4), (64, 64)) is None  # beside the view
    assert union(None, None) is None and union((1, 2, 3, 4), None) == (1, 2, 3, 4)
    assert union((0, 0, 10, 10), (5, 8, 10, 10)) == (0, 0, 15, 18)
    assert union(FULL, (0, 0, 1, 1)) == FULL


@pytest.mark.gpu
def test_every_frame_is_a_fresh_renderers(gl, monkeypatch):
    """A camera that turns and comes close, a head that moves, then none, then drawn again: the
    depth left by the last frame's head is cleared, and the clears are smaller than the target."""
    head = default_head(3)
    groom = default_groom(head, 60, 8)
    s = RenderSettings(size=(128, 96), rasterizer="compute", msaa=1)
    moved = np.eye(4)
    moved[:3, 3] = (0.03, 0.01, 0.0)
    steps = [(20, 1.0, None, True), (20, 1.0, None, True), (60, 0.8, None, True), (60, 0.8, moved, True),
             (100, 0.45, moved, True), (100, 0.45, moved, False), (30, 1.0, None, True)]

    def fresh(az, dist, transform, draw):
        r = Renderer(s.replace(draw_head=draw), ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(head)
            if transform is not None:
                r.set_head_transform(transform)
            return r.render_image(r.default_camera(azimuth=az, distance_scale=dist, points=None))
        finally:
            r.release()

    areas = []
    orig = moderngl.Framebuffer.clear

    def clear(self, *a, **k):
        if k.get("viewport") is not None:
            areas.append(k["viewport"][2] * k["viewport"][3])
        return orig(self, *a, **k)

    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        for az, dist, transform, draw in steps:
            r.settings = r.settings.replace(draw_head=draw)
            r.set_head_transform(np.eye(4) if transform is None else transform)
            monkeypatch.setattr(moderngl.Framebuffer, "clear", clear)
            img = r.render_image(r.default_camera(azimuth=az, distance_scale=dist, points=None))
            monkeypatch.setattr(moderngl.Framebuffer, "clear", orig)
            want = fresh(az, dist, transform, draw)
            assert np.array_equal(img, want), (az, dist, draw, int(np.abs(img.astype(int) - want).max()))
    finally:
        r.release()
    assert areas and min(areas) < 0.8 * 128 * 96
