"""The HDR depth cleared over the head's screen box of this frame and the last (render/screen_box.py):
the box against the projected points, the bounding points against every vertex, and every frame of
a moving camera, head and no head the picture a fresh renderer draws."""
from __future__ import annotations

import moderngl
import numpy as np
import pytest

import mane.render.passes.head_pass as head_pass
from mane.grooming.scene import default_groom, default_head
from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera, look_at, perspective
from mane.render.coverage_lod import box_corners
from mane.render.screen_box import CELLS, FULL, MAX_POINTS, bound_points, screen_box, union


def _pixels(view_proj, pts, model, size):
    c = np.c_[pts, np.ones(len(pts))] @ (view_proj @ model).T
    ndc = c[:, :2] / c[:, 3:]
    return (ndc + 1.0) * 0.5 * np.asarray(size)


_CORNERS = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)


def _view(rng, size):
    eye = rng.normal(0.0, 1.0, 3)
    eye *= rng.uniform(0.8, 1.5) / np.linalg.norm(eye)
    return perspective(40.0, size[0] / size[1], 0.05, 10.0) @ look_at(eye, (0.0, 0.0, 0.0))


@pytest.mark.parametrize("seed", range(6))
def test_the_box_holds_every_projected_point_and_little_more(seed):
    rng = np.random.default_rng(seed)
    size = (320, 200)
    pts = rng.normal(0.0, 0.1, (500, 3))
    model = np.eye(4)
    model[:3, 3] = rng.uniform(-0.1, 0.1, 3)
    vp = _view(rng, size)
    box = screen_box(vp, pts, model, size)
    px = _pixels(vp, pts, model, size)
    assert box not in (None, FULL)
    x, y, w, h = box
    lo, hi = np.clip(px.min(0), 0, size), np.clip(px.max(0), 0, size)
    # every point's pixel inside, and at most the rounding pixel and one more each side past them
    assert x <= lo[0] and x + w >= hi[0] and y <= lo[1] and y + h >= hi[1]
    assert x >= lo[0] - 2 and x + w <= hi[0] + 2 and y >= lo[1] - 2 and y + h <= hi[1] + 2


@pytest.mark.parametrize("seed", range(4))
def test_the_bounding_points_hold_every_vertex_in_any_view(seed):
    """A small mesh: the corners of its vertices' hull, a subset giving the exact box in any
    view. A large one: its occupied cells' corners (their hull's), a box that holds every
    vertex's pixel and is at most a cell's projection wider; both inside the bounding box
    corners' box. Made in O(vertices): a million in well under a second (the hull is only of
    the cells' corners)."""
    import time

    rng = np.random.default_rng(seed)
    size = (320, 200)
    small = rng.normal(0.0, 0.1, (MAX_POINTS, 3))
    kept = bound_points(small)
    assert len(kept) < len(small) // 4
    assert {tuple(p) for p in kept} <= {tuple(p) for p in small}
    for _ in range(20):
        vp, model = _view(rng, size), np.eye(4)
        model[:3, 3] = rng.uniform(-0.1, 0.1, 3)
        assert screen_box(vp, kept, model, size) == screen_box(vp, small, model, size)
    big = rng.normal(0.0, 1.0, (200_000, 3))
    big *= (0.08, 0.1, 0.09) / np.linalg.norm(big, axis=1, keepdims=True)   # a head-like shell
    t = time.perf_counter()
    pts = bound_points(big)
    assert time.perf_counter() - t < 1.0
    assert len(pts) < len(big) // 20
    cell = (big.max(0) - big.min(0)) / CELLS
    for _ in range(6):
        vp = _view(rng, size)
        model = np.eye(4)
        model[:3, 3] = rng.uniform(-0.1, 0.1, 3)
        exact, got = screen_box(vp, big, model, size), screen_box(vp, pts, model, size)
        corners = screen_box(vp, box_corners(big.min(0), big.max(0)), model, size)
        if FULL in (exact, got, corners):
            continue
        x, y, w, h = got
        ex, ey, ew, eh = exact
        assert x <= ex and y <= ey and x + w >= ex + ew and y + h >= ey + eh   # holds every vertex
        cx, cy, cw, ch = corners
        assert x >= cx and y >= cy and x + w <= cx + cw and y + h <= cy + ch
        # at most a cell looser: inside the box of every vertex moved by up to a cell each way
        loose = screen_box(vp, (big[:, None, :] + _CORNERS[None] * cell).reshape(-1, 3), model, size)
        if loose == FULL:
            continue
        lx, ly, lw, lh = loose
        assert x >= lx and y >= ly and x + w <= lx + lw and y + h <= ly + lh
    head = default_head(3)
    kept = bound_points(head.vertices)   # the default head: its hull's corners, the exact box
    assert len(kept) < len(head.vertices) // 2
    v = np.asarray(head.vertices, np.float64)
    for _ in range(20):
        vp = _view(rng, size)
        assert screen_box(vp, kept, np.eye(4), size) == screen_box(vp, v, np.eye(4), size)


def test_degenerate_meshes_keep_their_points():
    flat = np.c_[np.random.default_rng(0).uniform(-1, 1, (50_000, 2)), np.zeros(50_000)]
    pts = bound_points(flat)
    assert np.all(np.abs(pts[:, 2]) < 1e-5)   # a flat mesh's points stay flat, and hold it
    assert np.all(pts.min(0) <= flat.min(0)) and np.all(pts.max(0) >= flat.max(0))
    assert len(bound_points(np.zeros((3, 3)))) == 3
    vp = perspective(40.0, 1.0, 0.05, 10.0) @ look_at((0.0, 0.0, 3.0), (0.0, 0.0, 0.0))
    assert screen_box(vp, np.zeros((0, 3)), np.eye(4), (64, 64)) is None


def test_behind_the_eye_off_screen_and_unions():
    vp = perspective(40.0, 1.0, 0.05, 10.0) @ look_at((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    around = box_corners((-0.1, -0.1, 0.9), (0.1, 0.1, 1.1))
    assert screen_box(vp, around, np.eye(4), (64, 64)) == FULL   # around the eye
    beside = box_corners((5.0, 5.0, -0.1), (5.1, 5.1, 0.1))
    assert screen_box(vp, beside, np.eye(4), (64, 64)) is None  # beside the view
    assert union(None, None) is None and union((1, 2, 3, 4), None) == (1, 2, 3, 4)
    assert union((0, 0, 10, 10), (5, 8, 10, 10)) == (0, 0, 15, 18)
    assert union(FULL, (0, 0, 1, 1)) == FULL


@pytest.mark.gpu
@pytest.mark.parametrize("supersample, head_by_compute", [(1, False), (2, False), (1, True), (2, True)])
def test_every_frame_is_a_fresh_renderers(gl, monkeypatch, supersample, head_by_compute):
    """A camera that turns and comes close, a head that moves, then none, then drawn again: the
    depth left by the last frame's head is cleared, and the clears are smaller than the target
    (supersampled: the box in the target's pixels, not the output's); the head shaded by compute
    (GPUs) over that box only."""
    monkeypatch.setattr(head_pass, "SHADE_BY_COMPUTE", head_by_compute)
    head = default_head(3)
    groom = default_groom(head, 60, 8)
    s = RenderSettings(size=(128, 96), rasterizer="compute", msaa=1, supersample=supersample)
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
    assert areas and min(areas) < 0.8 * 128 * 96 * supersample ** 2
