"""The deep opacity map's own LOD (compute path): every m-th expanded strand scan-converted into
the light's map at m times the opacity, m = floor(D / lod_depth) for the map's depth complexity D
(coverage_lod.light_strand_step, DeepOpacityPass.strand_step).

Goldens: D of a flat box facing an orthographic light from the maths (N l max(w, texel) / area);
the stride's map bit for bit equal to the full dispatch over a buffer whose other strands are
zero-width (what the kernel skips) at the same opacity, and its z0 the full map's; the thinned map's opacity against the
full map's as a sum (the expectation is the same) and texel by texel.
"""
from __future__ import annotations

import numpy as np
import pytest

from mane.grooming.scene import default_scene
from mane.render import Renderer, RenderSettings
from mane.render.camera import look_at, orthographic
from mane.render.coverage_lod import box_corners, depth_complexity, light_strand_step
from mane.render.passes.base import View
from mane.render.passes import deep_opacity
from mane.render.passes.deep_opacity import DeepOpacityPass


def _ortho_light(radius=0.2, n=256):
    eye = np.array([0.0, 0.0, 1.0])
    vp = orthographic(radius, radius, 0.1, 3.0) @ look_at(eye, np.zeros(3))
    return View(vp, eye, np.array([0.0, 0.0, -1.0]), True, 2.0 * radius / n, 1.0)


@pytest.mark.parametrize("width,want_wide", [(0.004, True), (1e-5, False)])
def test_light_depth_complexity_of_a_flat_box(width, want_wide):
    n, radius = 256, 0.2
    view = _ortho_light(radius, n)
    a, b, N, l = 0.1, 0.05, 20000, 0.3
    lo, hi = np.array([-a, -b, 0.0]), np.array([a, b, 0.0])
    texel = 2.0 * radius / n
    D, visible = depth_complexity(view, (n, n), box_corners(lo, hi), N, l, width, 1.0)
    assert visible
    # N strands of l / texel texels, max(w / texel, 1) texels wide, over the box's (2a)(2b) / texel^2
    want = N * (l / texel) * max(width / texel, 1.0) / (4 * a * b / texel ** 2)
    assert D == pytest.approx(want, rel=1e-6)
    assert (width / texel > 1.0) == want_wide
    for lod in (16.0, 64.0, 1e4):
        m = light_strand_step(view, n, (lo, hi), N, l, width, lod)
        assert m == max(1, int(want // lod))
    assert light_strand_step(view, n, (lo, hi), N, l, width, 0.0) == 1   # lod_depth 0: off
    far = (lo + np.array([5.0, 0.0, 0.0]), hi + np.array([5.0, 0.0, 0.0]))
    assert light_strand_step(view, n, far, N, l, width, 16.0) == 1   # outside the map: no estimate


def _renderer(gl, groom, head, **kw):
    s = RenderSettings(**{"size": (64, 48), "msaa": 1, "rasterizer": "compute", "shadows": "deep_opacity",
                          "shadow_map_size": 96, "strands_per_guide": 6, **kw})
    r = Renderer(s, ctx=gl, profile=False)
    r.set_strands(groom)
    r.set_head(head)
    return r


def _dom(r, camera):
    r.render(camera)
    return r.get_pass("deep_opacity").read(), r.stats()


@pytest.mark.gpu
def test_the_stride_draws_every_mth_strand_at_m_times_the_opacity(gl, monkeypatch):
    groom, head = default_scene(num_guides=80, points=8, subdivisions=2)
    m, opacity = 3, 0.7
    monkeypatch.setattr(DeepOpacityPass, "strand_step", lambda self, frame: m)
    thinned = {}
    for z0_every in (True, False):   # z0 from every strand (the default) or the stride too
        monkeypatch.setattr(deep_opacity, "Z0_EVERY_STRAND", z0_every)
        r = _renderer(gl, groom, head, strand_opacity=opacity)
        try:
            cam = r.default_camera(25.0)
            thinned[z0_every], stats = _dom(r, cam)
            assert stats["dom_strand_step"] == m
        finally:
            r.release()
    monkeypatch.setattr(DeepOpacityPass, "strand_step", lambda self, frame: 1)
    r = _renderer(gl, groom, head, strand_opacity=opacity)
    try:
        every, _ = _dom(r, cam)
    finally:
        r.release()
    np.testing.assert_array_equal(thinned[True][..., 3], every[..., 3])
    monkeypatch.setattr(DeepOpacityPass, "strand_step", lambda self, frame: 1)
    r = _renderer(gl, groom, head, strand_opacity=opacity * m)   # the uniform the stride sets
    try:
        r.render(cam)
        expand = r.get_pass("expand")
        pts = expand.read()
        keep = np.arange(len(pts)) % m == 0
        pts[~keep, :, 3] = 0.0   # zero width: the kernels skip the strand
        expand.buffer.write(pts.astype(np.float32).tobytes())
        r.get_pass("deep_opacity").kept = None   # written behind the renderer's back: the map drawn again
        full, stats = _dom(r, cam)
        assert np.array_equal(expand.read(), pts), "the renderer expanded again"
        assert stats["dom_strand_step"] == 1
    finally:
        r.release()
    assert (full[..., 3] < 1e8).sum() > 300 and full[..., :3].max() > 1.0
    np.testing.assert_array_equal(thinned[False], full)


@pytest.mark.gpu
def test_the_thinned_map_keeps_the_opacity(gl, monkeypatch):
    groom, head = default_scene(num_guides=300, points=8, subdivisions=2)
    maps = {}
    for m in (1, 4):
        monkeypatch.setattr(DeepOpacityPass, "strand_step", lambda self, frame, m=m: m)
        r = _renderer(gl, groom, head, strands_per_guide=16, shadow_map_size=64)
        try:
            maps[m], _ = _dom(r, r.default_camera(25.0))
        finally:
            r.release()
    full, thin = maps[1], maps[4]
    for layer in range(3):
        total = full[..., layer].sum()
        assert total > 0
        assert thin[..., layer].sum() == pytest.approx(total, rel=0.05)
    # texel by texel where the hair is deep (the last layer's opacity, every strand of the column)
    deep = full[..., 2] > np.percentile(full[..., 2][full[..., 2] > 0], 50)
    rel = np.abs(thin[..., 2][deep] - full[..., 2][deep]).mean() / full[..., 2][deep].mean()
    assert rel < 0.15, rel
    # z0, the nearest strand of fewer, lies no nearer
    hit = (full[..., 3] < 1e8) & (thin[..., 3] < 1e8)
    assert (thin[..., 3][hit] >= full[..., 3][hit] - 1e-6).all()


class _Frame:
    def __init__(self, light_view):
        self.light_view = light_view


def _step_at(r, camera) -> int:
    """The map's stride for ``camera``'s frame, with the strands expanded and nothing drawn."""
    from mane.render.lights import default_lights

    r.lod_view = r.camera_view(camera)
    r.lod_eye = r.lod_view.eye
    r.get_pass("expand").ensure()
    return r.get_pass("deep_opacity").strand_step(_Frame(r.light_view(default_lights()[0])))


@pytest.mark.gpu
def test_default_scenes_draw_every_strand_into_the_map(gl):
    """The 50k-strand 1080p target frame and the fidelity bench's curly head: m = 1 (their maps
    are what they were)."""
    from mane.bench import fidelity as F
    from mane.bench.render_bench import TARGET_GUIDES, TARGET_POINTS, TARGET_SIZE, TARGET_SPG
    from mane.grooming.scene import default_groom, default_head

    head = default_head(4)
    groom = default_groom(head, TARGET_GUIDES, TARGET_POINTS)
    scene = F.SCENES["curly_head"]
    g, h = F.load_scene(scene, 300)
    cases = [(groom, head, RenderSettings(size=TARGET_SIZE, strands_per_guide=TARGET_SPG, rasterizer="compute"), 1),
             (g, h, F.base_settings(scene, (320, 320), rasterizer="compute"), 1)]
    for g_, h_, s, want in cases:
        r = Renderer(s, ctx=gl, profile=False)
        try:
            r.set_strands(g_)
            r.set_head(h_)
            assert _step_at(r, r.default_camera()) == want
        finally:
            r.release()
