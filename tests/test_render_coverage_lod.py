"""Coverage-driven strand LOD (mane.render.coverage_lod, settings.lod_depth) and instances.

Goldens from the maths: a flat box of strands facing the camera has D = N l w / (box area)
whatever the camera (the pixel size cancels) while the strands are wider than the narrowest
drawn width m, and N l m px d / area when they are narrower. The expansion with the LOD acting
is the full expansion's first k strands of every guide, widened by strands_per_guide / k.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera
from mane.render.coverage_lod import (SEGMENT_PX, LodPlan, depth_complexity, kept_per_guide, lod_plan,
                                      mean_strand_length)
from mane.render.passes.base import View, subdivisions
from test_render_compute import drawn_directions


def _view(fov=30.0, size=(400, 300), eye=(0.0, 0.0, 2.0)):
    cam = Camera(eye=eye, target=(0.0, 0.0, 0.0), fov_y=fov, near=0.1, far=10.0)
    w, h = size
    vp = cam.projection(w / h) @ cam.view()
    pixel = 2.0 * math.tan(math.radians(fov) / 2.0) / h
    return View(vp, np.asarray(cam.eye, float), cam.forward, False, pixel, 1.0)


def _flat_box(a, b):
    return np.array([[x, y, 0.0] for x in (-a, a) for y in (-b, b) for _ in (0, 1)])


@pytest.mark.parametrize("fov,eye_z", [(30.0, 2.0), (50.0, 1.3)])
def test_depth_complexity_of_a_flat_box_is_n_l_w_over_its_area(fov, eye_z):
    view = _view(fov, eye=(0.0, 0.0, eye_z))
    N, l, w, a, b = 5000, 0.3, 0.004, 0.1, 0.15
    # wide strands (w_px > m): the pixel size cancels
    D, visible = depth_complexity(view, (400, 300), _flat_box(a, b), N, l, w, 0.5)
    assert visible
    assert D == pytest.approx(N * l * w / (4 * a * b), rel=1e-9)
    # thin strands drawn m = 1 px wide: N l_px m / A_px, l_px = l / (px d), A_px = 4ab / (px d)^2
    px_d = view.pixel_size * eye_z
    assert w / px_d < 3.0
    D1, _ = depth_complexity(view, (400, 300), _flat_box(a, b), N, l, 1e-6, 3.0)
    assert D1 == pytest.approx(N * (l / px_d) * 3.0 / (4 * a * b / px_d ** 2), rel=1e-9)


def test_boxes_behind_the_eye_are_not_thinned_and_boxes_outside_are_culled():
    view = _view()
    behind = _flat_box(0.1, 0.1) + np.array([0.0, 0.0, 3.0])
    D, visible = depth_complexity(view, (400, 300), behind, 10 ** 6, 0.3, 0.001, 1.0)
    assert math.isinf(D) and visible
    plan = lod_plan(view, (400, 300), [(np.array([5.0, -0.1, -0.1]), np.array([5.2, 0.1, 0.1])),
                                       (np.array([-0.1, -0.1, -0.1]), np.array([0.1, 0.1, 0.1]))],
                    strands_per_guide=16, guides=1000, mean_length=0.3, mean_width=0.001, min_width_px=1.0,
                    lod_depth=64.0)
    assert plan.kept[0] == 0 and plan.kept[1] >= 1
    assert plan.width_scale[0] == 1.0


@pytest.mark.parametrize("spg,D,target,want", [(16, 128.0, 64.0, 8), (16, 64.0, 64.0, 16), (16, 10.0, 64.0, 16),
                                                (320, 326.0, 64.0, 63), (16, 1e9, 64.0, 1), (16, 1e3, 0.0, 16)])
def test_kept_per_guide(spg, D, target, want):
    assert kept_per_guide(spg, D, target) == want


@pytest.mark.parametrize("length_px,full,guide_segments,want", [
    (30.0, 2, 16, 1),          # 7.5 segments wanted over 16 guide segments: the guide's own
    (100.0, 2, 16, 2),         # 25 wanted over 16: 2, the settings' 2 a guide segment
    (40.0, 8, 5, 2),           # 10 wanted over 5 guide segments: 2 a segment
    (float("inf"), 4, 5, 4),   # behind the eye: no estimate
])
def test_segment_lod_subdivisions(length_px, full, guide_segments, want):
    plan = LodPlan((100.0,), (2,), 4, (length_px,))   # thinned: 2 of 4 strands kept
    assert SEGMENT_PX == 4.0
    assert plan.subdivisions(full, guide_segments) == want
    # a culled instance does not count; one that keeps every strand keeps every segment too
    assert LodPlan((100.0, 0.0), (2, 0), 4, (length_px, 1e9)).subdivisions(full, guide_segments) == want
    assert LodPlan((100.0, 1.0), (2, 4), 4, (length_px, 1.0)).subdivisions(full, guide_segments) == full


def test_mean_strand_length():
    p = np.zeros((2, 3, 3))
    p[0, :, 0] = [0.0, 1.0, 3.0]     # length 3
    p[1, :, 1] = [0.0, 0.5, 1.5]     # length 1.5
    assert mean_strand_length(p) == pytest.approx(2.25)


# ---------------------------------------------------------------- the default scenes are untouched
def test_default_scenes_keep_every_strand(gl):
    """The 50k-strand 1080p target frame (both rasterisers) and the fidelity bench's scenes: p = 1."""
    from mane.bench import fidelity as F
    from mane.bench.render_bench import TARGET_GUIDES, TARGET_POINTS, TARGET_SIZE, TARGET_SPG
    from mane.grooming.scene import default_groom, default_head

    head = default_head(4)
    groom = default_groom(head, TARGET_GUIDES, TARGET_POINTS)
    scenes = [(groom, head, RenderSettings(size=TARGET_SIZE, strands_per_guide=TARGET_SPG, rasterizer=rz))
              for rz in ("hardware", "compute")]
    scene = F.SCENES["curly_head"]
    g, h = F.load_scene(scene, 300)
    scenes += [(g, h, F.base_settings(scene, (320, 320), rasterizer=rz)) for rz in ("hardware", "compute")]
    for g, h, s in scenes:
        assert s.lod_depth == RenderSettings().lod_depth > 0
        r = Renderer(s, ctx=gl, profile=False)
        try:
            r.set_strands(g)
            r.set_head(h)
            plan = r.lod_plan(r.camera_view(r.default_camera()))
            assert plan.kept == (s.strands_per_guide,), (s.size, plan)
            assert plan.depth[0] < 0.5 * s.lod_depth   # with margin
            N = r.strands.points_per_strand
            full = subdivisions(s, N)
            assert plan.subdivisions(full, N - 1) == full   # no segment LOD either
        finally:
            r.release()


# ---------------------------------------------------------------- the expansion
def _groom(guides=24, points=6, seed=3):
    from mane.groom import Groom

    rng = np.random.default_rng(seed)
    roots = rng.uniform(-0.05, 0.05, (guides, 3))
    t = np.linspace(0.0, 1.0, points)[:, None]
    pts = roots[:, None, :] + t[None] * np.array([0.0, -0.25, 0.02]) + 0.01 * np.sin(7 * t)[None]
    return Groom.from_strands(list(pts.astype(np.float32)))


def _expanded(gl, groom, camera, instances=None, **kw):
    r = Renderer(RenderSettings(**{"size": (64, 48), "msaa": 1, "pipeline": "compute", "shadows": "none",
                                   "strands_per_guide": 8, **kw}), ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        if instances is not None:
            r.set_instances(instances)
        r.render(camera)
        return r.get_pass("expand").read(), r.lod_plan(), r.stats()
    finally:
        r.release()


@pytest.mark.gpu
def test_lod_expands_the_first_k_strands_of_each_guide_widened(gl):
    g = _groom()
    cam = Camera(eye=(0.0, -0.1, 0.6), target=(0.0, -0.1, 0.0), fov_y=40.0)
    # segments=5: one subdivision a guide segment, which the segment LOD cannot lower
    full, plan0, _ = _expanded(gl, g, cam, lod_depth=0.0, segments=5)
    assert plan0.kept == (8,)
    lod, plan, stats = _expanded(gl, g, cam, lod_depth=0.05, segments=5)   # far below the scene's D
    k = plan.kept[0]
    assert 1 <= k < 8 and math.isfinite(plan.depth[0]) and plan.depth[0] > 0.05
    G, P = g.num_strands, full.shape[1]
    assert lod.shape == (G * k, P, 8)
    want = full.reshape(G, 8, P, 8)[:, :k].reshape(G * k, P, 8).copy()
    want[..., 3] *= 8.0 / k
    np.testing.assert_allclose(lod, want, rtol=1e-6, atol=1e-7)
    assert stats["strands_expanded"] == G * k and stats["strands_full"] == G * 8
    assert stats["lod_keep_fraction"] == pytest.approx(k / 8)


@pytest.mark.gpu
def test_segment_lod_keeps_the_guide_knots(gl):
    """Fewer subdivisions where strands look short: the points at the guide's knots are the
    full expansion's (the same curve, sampled less often)."""
    g = _groom()
    N = g.uniform_count
    cam = Camera(eye=(0.0, -0.1, 3.0), target=(0.0, -0.1, 0.0), fov_y=40.0)
    full, _, _ = _expanded(gl, g, cam, lod_depth=0.0, segments=40)
    lod, plan, _ = _expanded(gl, g, cam, lod_depth=1e-6, segments=40)   # thinned to 1 a guide: segments reduced
    assert plan.kept == (1,)
    full = full[:, :, :].reshape(g.num_strands, 8, full.shape[1], 8)[:, 0].copy()   # strand 0 of each guide
    full[..., 3] *= 8.0
    sub_full = (full.shape[1] - 1) // (N - 1)
    sub = plan.subdivisions(sub_full, N - 1)
    assert sub_full == 8 and 1 <= sub < sub_full
    # the estimate: a strand's projected length over SEGMENT_PX, spread over the guide segments
    assert sub == math.ceil(plan.length_px[0] / SEGMENT_PX / (N - 1))
    assert lod.shape == (g.num_strands, (N - 1) * sub + 1, 8)
    keep = [0, 1, 2, 3, 7]   # position, width, strand random (the tangent: the drawn points' direction, below)
    np.testing.assert_allclose(lod[:, ::sub][..., keep], full[:, ::sub_full][..., keep], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(lod[..., 4:7], drawn_directions(lod[..., :3]), atol=2e-5)


def test_segment_levels_per_instance():
    plan = LodPlan((100.0, 10.0, 100.0), (2, 4, 0), 4, (40.0, 500.0, 40.0))
    assert plan.levels(8, 5) == (2, 8, 8)   # thinned and short: 2; keeps every strand or culled: all 8


@pytest.mark.gpu
def test_a_far_thinned_instance_uses_fewer_segments(gl):
    g = _groom()
    N = g.uniform_count
    cam = Camera(eye=(0.0, -0.1, 0.5), target=(0.0, -0.1, 0.0), fov_y=40.0)
    m = np.tile(np.eye(4), (2, 1, 1))
    m[1, :3, 3] = (0.0, 0.0, -6.0)     # far behind the first
    full, plan0, _ = _expanded(gl, g, cam, instances=m, lod_depth=0.0, segments=10)
    _, probe, _ = _expanded(gl, g, cam, instances=m, lod_depth=1e6, segments=10)
    lo, hi = probe.depth
    assert lo < hi
    lod, plan, _ = _expanded(gl, g, cam, instances=m, lod_depth=math.sqrt(lo * hi), segments=10)
    assert plan.kept[0] == 8 and plan.kept[1] < 8
    sub = (full.shape[1] - 1) // (N - 1)
    level = plan.levels(sub, N - 1)
    assert level[0] == sub and 1 <= level[1] < sub
    n = g.num_strands * 8
    np.testing.assert_allclose(lod[:n], full[:n], rtol=1e-6, atol=1e-7)   # the near head as it was
    far = lod[n:].reshape(g.num_strands, plan.kept[1], -1, 8)[..., :3]
    ref = full[n:].reshape(g.num_strands, 8, -1, 8)[:, :plan.kept[1], :, :3]
    L = level[1]
    for seg in range(N - 1):
        for k in range(sub):
            if k >= L:     # past the level: the segment's end, the next knot
                want = ref[:, :, (seg + 1) * sub]
            elif (k * sub) % L == 0:   # u = k / L is a point of the full expansion
                want = ref[:, :, seg * sub + k * sub // L]
            else:
                continue
            np.testing.assert_allclose(far[:, :, seg * sub + k], want, rtol=1e-5, atol=1e-5)


@pytest.mark.gpu
def test_instances_are_the_groom_moved(gl):
    g = _groom()
    cam = Camera(eye=(0.15, -0.1, 1.2), target=(0.15, -0.1, 0.0), fov_y=40.0)
    one, _, _ = _expanded(gl, g, cam, lod_depth=0.0)
    m = np.tile(np.eye(4), (3, 1, 1))
    m[1, :3, 3] = (0.15, 0.0, 0.0)
    c, s = math.cos(0.3), math.sin(0.3)
    m[2, :3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    m[2, :3, 3] = (0.3, 0.0, -0.1)
    many, plan, stats = _expanded(gl, g, cam, instances=m, lod_depth=0.0)
    n = len(one)
    assert many.shape == (3 * n,) + one.shape[1:] and plan.kept == (8, 8, 8)
    for i in range(3):
        part = many[i * n:(i + 1) * n]
        np.testing.assert_allclose(part[..., :3], one[..., :3] @ m[i, :3, :3].T + m[i, :3, 3], atol=2e-6)
        np.testing.assert_allclose(part[..., 4:7], one[..., 4:7] @ m[i, :3, :3].T, atol=2e-6)
        np.testing.assert_array_equal(part[..., 3], one[..., 3])
    assert stats["instances"] == 3


def test_bad_instances_are_refused(gl):
    from mane.errors import UsageError

    r = Renderer(RenderSettings(size=(32, 32)), ctx=gl, profile=False)
    try:
        with pytest.raises(UsageError, match="4x4"):
            r.set_instances(np.zeros((2, 3, 3)))
        with pytest.raises(UsageError, match="4x4"):
            r.set_instances([])
    finally:
        r.release()


@pytest.mark.gpu
def test_the_lod_expands_only_what_a_small_frame_needs(gl, monkeypatch):
    """10 guides x 4096 strands x 257 points at 32x32: 337 MB expanded in full, beyond a 64 MiB
    budget (tests/test_robustness.py refuses it with the LOD off); with it the frame keeps a few
    strands a guide and few segments, and renders."""
    monkeypatch.setenv("MANE_GPU_MEMORY", "64M")
    g = _groom(guides=10)
    # the raster units, which every GPU has and llvmpipe takes by default (the compute rasteriser,
    # an H200's default, draws thin strands half as wide: D halves and it keeps twice the strands)
    r = Renderer(RenderSettings(size=(32, 32), strands_per_guide=4096, segments=256, shadows="none",
                                rasterizer="hardware"), ctx=gl, profile=False)
    try:
        r.set_strands(g)
        img = r.render_image()
        st = r.stats()
        assert st["strands_expanded"] < 0.05 * st["strands_full"]
        assert r.get_pass("expand").points < 257
        assert img.std() > 0   # something drawn
    finally:
        r.release()
