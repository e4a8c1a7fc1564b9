"""settings.ms_smoothing (render/passes/ms_smooth.py): the compute rasteriser's multiply scattered
light smoothed across the hair. ms_smooth.comp against its NumPy twin; the twin leaves a uniform
field as it is whatever the coverage; and in a frame the split is exact (the shading pass's
direct light plus its multiply scattered target is the unsplit frame) and the smoothing is the
twin's."""
from __future__ import annotations

import numpy as np
import pytest

from mane.render import Renderer, RenderSettings
from mane.render.passes import ms_smooth

H, W = 40, 56


def _fields(seed=0):
    rng = np.random.default_rng(seed)
    cover = np.where(rng.uniform(size=(H, W)) < 0.3, 0.0, rng.uniform(0.05, 1.0, (H, W)))
    radiance = rng.uniform(0.0, 2.0, (H, W, 3))
    ms = np.concatenate([radiance * cover[..., None], cover[..., None]], -1)
    hdr = np.concatenate([rng.uniform(0.0, 1.0, (H, W, 3)), rng.uniform(0.0, 1.0, (H, W, 1))], -1)
    return ms.astype(np.float16).astype(np.float64), hdr.astype(np.float16).astype(np.float64)


def test_twin_leaves_a_uniform_field_as_it_is_whatever_the_coverage():
    rng = np.random.default_rng(1)
    cover = np.where(rng.uniform(size=(H, W)) < 0.3, 0.0, rng.uniform(0.05, 1.0, (H, W)))
    c = np.array([0.7, 0.4, 0.2])
    ms = np.concatenate([c * cover[..., None], cover[..., None]], -1)
    out = ms_smooth.smooth_numpy(ms, np.zeros((H, W, 4)), 2.5)
    np.testing.assert_allclose(out[..., :3], c * cover[..., None], atol=1e-12)
    # a field that varies: smoothed (its pixels move toward their neighbours), nothing where no hair
    ms2 = ms.copy()
    ms2[..., :3] *= rng.uniform(0.5, 1.5, (H, W, 1))
    out2 = ms_smooth.smooth_numpy(ms2, np.zeros((H, W, 4)), 2.5)
    assert np.all(out2[cover == 0] == 0.0)
    per = out2[..., 0][cover > 0] / cover[cover > 0]
    assert per.std() < 0.5 * (ms2[..., 0][cover > 0] / cover[cover > 0]).std()


@pytest.mark.parametrize("sigma", [1.2, 1.5, 3.0, 4.9, 5.0, 6.0, 8.0])
def test_twin_spreads_a_point_by_sigma_on_any_grid(sigma):
    """A point of radiance on uniformly covered hair comes out spread with the variance of a
    Gaussian of sigma pixels (per axis), whatever the cells (1, 2 or 4 pixels a side) and where
    in its cell the point lies."""
    n = 96
    ms = np.zeros((n, n, 4))
    ms[..., 3] = 1.0
    f = ms_smooth.factor(sigma)
    var = []
    for dy in range(f):
        for dx in range(f):
            m = ms.copy()
            c = (n // 2 + dy, n // 2 + dx)
            m[c[0], c[1], 0] = 1.0
            out = ms_smooth.smooth_numpy(m, np.zeros((n, n, 4)), sigma)[..., 0]
            assert out.sum() == pytest.approx(1.0, rel=0.02)
            y, x = np.mgrid[:n, :n]
            w = out / out.sum()
            var.append(((x - (w * x).sum()) ** 2 * w).sum())
            var.append(((y - (w * y).sum()) ** 2 * w).sum())
    assert np.mean(var) == pytest.approx(sigma * sigma, rel=0.05), (f, np.mean(var))


def test_sigma_is_the_width_in_pixels_at_the_hair():
    from mane.render.passes.base import View

    persp = View(np.eye(4), np.zeros(3), np.array([0.0, 0.0, -1.0]), False, 0.001, 1.0)   # 1 mm a pixel at 1 m
    assert ms_smooth.sigma_pixels(persp, 0.003, (0.0, 0.0, -2.0)) == pytest.approx(1.5)
    ortho = View(np.eye(4), np.zeros(3), np.array([0.0, 0.0, -1.0]), True, 0.0005, 1.0)
    assert ms_smooth.sigma_pixels(ortho, 0.003, (0.0, 0.0, -9.0)) == pytest.approx(6.0)
    assert ms_smooth.sigma_pixels(ortho, 0.03, (0.0, 0.0, -9.0)) == ms_smooth.MAX_SIGMA


@pytest.mark.gpu
@pytest.mark.parametrize("sigma", [0.7, 2.5, 4.0, 8.0])   # cells of 1, 2, 2 and 4 pixels
def test_glsl_smoothing_matches_its_twin(gl, sigma):
    ms, hdr = _fields()
    tex = {}
    for name, a in (("ms", ms), ("hdr", hdr)):
        tex[name] = gl.texture((W, H), 4, data=a.astype(np.float16).tobytes(), dtype="f2")
    grid = ms_smooth.grid_textures(gl, ms_smooth.low_size((W, H), ms_smooth.factor(sigma)))
    try:
        ms_smooth.smooth(gl, tex["ms"], grid, tex["hdr"], sigma)
        got = np.frombuffer(tex["hdr"].read(), np.float16).reshape(H, W, 4).astype(np.float64)
    finally:
        for t in (*tex.values(), *grid):
            t.release()
    want = ms_smooth.smooth_numpy(ms, hdr, sigma)
    # half floats: the result rounded to 11 bits
    np.testing.assert_allclose(got, want, rtol=4e-3, atol=4e-3)


def _scene():
    from mane.grooming.scene import default_scene

    return default_scene(num_guides=60, points=10, subdivisions=2)


PLATINUM = {"melanin": (0.06, 0.02)}   # light hair: its multiply scattered light is a large share


@pytest.mark.gpu
@pytest.mark.parametrize("kind", [dict(rasterizer="compute"),
                                  dict(rasterizer="compute", head_msaa=True),   # the shading's colour is the head's resolve
                                  dict(rasterizer="hardware"),                  # MSAA 4: the same sample mask
                                  dict(rasterizer="hardware", msaa=1)])         # blended by coverage
def test_in_a_frame_the_split_is_exact_and_the_smoothing_is_the_twins(gl, monkeypatch, kind):
    groom, head = _scene()

    def frame(**kw):
        r = Renderer(RenderSettings(size=(96, 72), shading_options=PLATINUM, **kind, **kw), ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(head)
            r.render(r.default_camera())
            color = r.hdr_textures()[0]
            hdr = np.frombuffer(color.read(), np.float16).reshape(72, 96, 4).astype(np.float64)
            p = r.get_pass("ms_smooth")
            ms = (np.frombuffer(p._targets[1].read(), np.float16).reshape(72, 96, 4).astype(np.float64)
                  if p._targets is not None and ms_smooth.active(r) else None)
            lo, hi = r.hair_bbox()
            sigma = ms_smooth.sigma_pixels(r.last_frame.view, float(r.settings.ms_smoothing), 0.5 * (lo + hi))
            return hdr, ms, sigma
        finally:
            r.release()

    width = 0.012   # metres: a few pixels at this size, so that the reduced grid is used too
    whole, none, _ = frame(ms_smoothing=0.0)
    assert none is None
    smoothed, cleared, sigma = frame(ms_smoothing=width)
    assert sigma > 1.5, sigma
    assert not cleared.any()   # the smoothing leaves its input clear for the next frame
    monkeypatch.setattr(ms_smooth.MsSmoothPass, "run", lambda self, f: None)
    direct, ms, _ = frame(ms_smoothing=width)
    hair = ms[..., 3] > 0
    assert hair.sum() > 300 and np.median(ms[..., 0][hair] / ms[..., 3][hair]) > 0.005
    # the direct light plus the multiply scattered light as written: the unsplit frame (half floats)
    np.testing.assert_allclose(direct[..., :3] + ms[..., :3], whole[..., :3], rtol=3e-3, atol=3e-4)
    np.testing.assert_array_equal(direct[..., 3], whole[..., 3])
    # and what the pass adds is the twin's, which differs from the term as written
    added, want = smoothed - direct, ms_smooth.smooth_numpy(ms, np.zeros_like(ms), sigma)
    # (the sum is rounded to a half float once: one unit in its last place, 2^-11 of it)
    ulp = np.spacing(np.abs(smoothed).astype(np.float16)).astype(np.float64)
    assert np.all(np.abs(added - want) <= 1e-2 * np.abs(want) + ulp + 1e-5), np.abs(added - want).max()
    assert np.abs(want[..., :3] - ms[..., :3]).max() > 30 * 3e-4


@pytest.mark.gpu
def test_only_a_frame_without_transparency_smooths(gl):
    groom, head = _scene()
    for kw, on in ((dict(rasterizer="compute", ms_smoothing=0.003), True), (dict(rasterizer="hardware", ms_smoothing=0.003), True),
                   (dict(rasterizer="compute", oit="k_buffer", ms_smoothing=0.003), False), (dict(rasterizer="compute"), True),
                   (dict(rasterizer="compute", ms_smoothing=0.0), False)):
        r = Renderer(RenderSettings(size=(48, 36), **kw), ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            f = r.render(r.default_camera())
            assert r.get_pass("ms_smooth").enabled(f) == on, kw
        finally:
            r.release()


@pytest.mark.gpu
@pytest.mark.parametrize("kind", [dict(rasterizer="compute"), dict(rasterizer="hardware"),
                                  dict(rasterizer="hardware", msaa=1)])
def test_a_frame_after_another_equals_a_fresh_renderers(gl, kind):
    """The split target is written only where there is hair; the smoothing clears what it read,
    so a frame after another (the camera moved) carries none of the last frame's light."""
    groom, head = _scene()
    s = RenderSettings(size=(96, 72), shading_options=PLATINUM, ms_smoothing=0.012, **kind)

    def hdr(r):
        return np.frombuffer(r.hdr_textures()[0].read(), np.float16).reshape(72, 96, 4).astype(np.float64)

    frames = []
    for cams in (("side", "front"), ("front",)):
        r = Renderer(s, ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(head)
            for c in cams:
                r.render(r.default_camera(azimuth=90.0) if c == "side" else r.default_camera())
            frames.append(hdr(r))
        finally:
            r.release()
    np.testing.assert_allclose(frames[0], frames[1], atol=1e-3)
