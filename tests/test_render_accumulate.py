"""A still scene's frames averaged (RenderSettings.accumulate, render/passes/accumulate.py): the
jitter against the Halton sequence and the projection's maths, the GPU's running mean against
NumPy's mean of the same frames, what resets it, and what it buys against more samples."""
from __future__ import annotations

import numpy as np
import pytest

from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera, look_at, orthographic, perspective
from mane.render.passes.accumulate import halton, jittered_view, still_jitter
from mane.render.passes.base import View
from test_render_tessellation import wavy_groom


def test_halton_points_are_the_radical_inverses():
    assert [halton(k, 2) for k in (1, 2, 3, 4, 5)] == [0.5, 0.25, 0.75, 0.125, 0.625]
    assert np.allclose([halton(k, 3) for k in (1, 2, 3, 4, 5)], [1 / 3, 2 / 3, 1 / 9, 4 / 9, 7 / 9])


@pytest.mark.parametrize("grid", [1, 2, 4])
def test_still_jitter_fills_a_sample_cell_evenly(grid):
    pts = np.array([still_jitter(k, grid) for k in range(1, 17)])
    assert np.all(np.abs(pts) < 0.5 / grid)
    # 16 points: each quarter of the cell along x gets 4 (base 2), every third along y 5 or 6 (base 3)
    qx = np.floor((pts[:, 0] * grid + 0.5) * 4).astype(int)
    assert np.bincount(qx, minlength=4).tolist() == [4, 4, 4, 4]
    ty = np.floor((pts[:, 1] * grid + 0.5) * 3).astype(int)
    assert sorted(np.bincount(ty, minlength=3).tolist()) == [5, 5, 6]
    assert np.all(np.abs(pts.mean(axis=0)) < 0.06 / grid)


def _window(vp, p, size):
    clip = vp @ np.append(p, 1.0)
    ndc = clip[:3] / clip[3]
    return np.array([(ndc[0] + 1) * 0.5 * size[0], (ndc[1] + 1) * 0.5 * size[1], ndc[2]])


@pytest.mark.parametrize("ortho", [False, True])
def test_jittered_view_moves_every_point_by_the_offset_in_pixels(ortho):
    size = (320, 240)
    view = look_at((0.3, 0.2, 1.5), (0.0, 0.0, 0.0))
    proj = orthographic(0.4, 0.3, 0.1, 5.0) if ortho else perspective(30.0, size[0] / size[1], 0.1, 5.0)
    v = View(proj @ view, np.array([0.3, 0.2, 1.5]), np.array([0.0, 0.0, -1.0]), ortho, 0.01, 1.0)
    j = jittered_view(v, 0.3, -0.2, size)
    rng = np.random.default_rng(3)
    for p in rng.uniform(-0.2, 0.2, (8, 3)):
        a, b = _window(v.view_proj, p, size), _window(j.view_proj, p, size)
        assert np.allclose(b - a, [0.3, -0.2, 0.0], atol=1e-9)
    assert j.pixel_size == v.pixel_size and j.ortho == v.ortho and v.view_proj is not j.view_proj
    assert v.min_pixel_width == 1.0 and j.min_pixel_width == 0.0   # strands at their true width


def _renderer(gl, **kw):
    s = RenderSettings(**{"size": (64, 48), "strands_per_guide": 4, "shadows": "deep_opacity",
                          "shadow_map_size": 256, "draw_head": False, **kw})
    r = Renderer(s, ctx=gl, profile=False)
    r.set_strands(wavy_groom(guides=6, points=8))
    return r


def _hdr(tex, size):
    raw = np.frombuffer(tex.read(), np.float16 if tex.dtype == "f2" else np.float32)
    return raw.reshape(size[1], size[0], 4).astype(np.float64)


@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_the_shown_colour_is_the_mean_of_the_still_frames(gl, rasterizer):
    n = 4
    r = _renderer(gl, rasterizer=rasterizer, accumulate=n)
    try:
        cam = r.default_camera()
        own, shown, places = [], [], []
        for _ in range(n + 3):
            frame = r.render(cam, refine=True)
            places.append(frame.still)
            own.append(_hdr(r.resolved_hdr(), r.settings.size))
            shown.append(_hdr(r.shown_hdr(), r.settings.size))
        assert places == list(range(n + 3))
        assert np.array_equal(shown[0], own[0])          # the first frame alone, at the pixel centres
        for k in range(1, n + 1):
            mean = np.mean(own[1:k + 1], axis=0)
            assert np.allclose(shown[k], mean, atol=2e-6 + 1e-6 * np.abs(mean).max()), k
            assert r.still_frames == n if k == n else True
        for k in (n + 1, n + 2):                          # full: the mean is kept
            assert np.array_equal(shown[k], shown[n])
        # the frames in the mean differ (they are moved); after it, frames are drawn at the centres
        assert not np.allclose(own[1], own[0]) and not np.allclose(own[2], own[1])
        assert np.abs(own[n + 1] - own[0]).max() <= 1.0 / 255
        assert r.still_frames == n
    finally:
        r.release()


def test_a_change_starts_again_and_shows_the_new_frame_as_it_is(gl):
    r = _renderer(gl)
    other = _renderer(gl)
    try:
        cam = r.default_camera()
        r.render_still(cam)
        assert r.still_frames == 16 and r.frames_rendered == 17
        moved = cam.orbited(10.0)
        assert r.render(moved, refine=True).still == 0 and r.still_frames == 0
        assert np.abs(r.read_image().astype(int) - other.render_image(moved)).max() <= 1
        assert r.render(moved, refine=True).still == 1
        r.settings = r.settings.replace(exposure=1.5)    # a setting, the lights and new strands reset it
        assert r.render(moved, refine=True).still == 0
        assert r.render(moved, refine=True).still == 1
        from mane.render.lights import Light

        lit = [Light("directional", (0.0, 1.0, 0.0))]
        assert r.render(moved, lit, refine=True).still == 0
        r.set_strands(wavy_groom(guides=5, points=8))
        assert r.render(moved, lit, refine=True).still == 0
        assert r.render(moved, lit, refine=True).still == 1
        r.strands_changed()                              # positions written
        assert r.render(moved, lit, refine=True).still == 0
        assert r.render(moved, lit).still == 0            # a frame that does not refine: drawn as it is
        assert r.still_frames == 0 and r.shown_hdr() is r.resolved_hdr()
        assert r.render(moved, lit, refine=True).still == 0
    finally:
        r.release()
        other.release()


def test_accumulate_one_draws_every_frame_as_it_is(gl):
    r = _renderer(gl, accumulate=1)
    try:
        cam = r.default_camera()
        first = r.render_still(cam)
        assert r.frames_rendered == 1 and r.still_frames == 0
        assert r.render(cam, refine=True).still == 0 and r.shown_hdr() is r.resolved_hdr()
        assert np.abs(r.read_image().astype(int) - first).max() <= 1
    finally:
        r.release()


def test_a_simulators_hair_is_still_until_it_steps(gl):
    from mane.sim import SimSettings, Simulator

    sim = Simulator(wavy_groom(guides=6, points=8), settings=SimSettings(grid_resolution=16), ctx=gl)
    r = Renderer(RenderSettings(size=(64, 48), strands_per_guide=2, draw_head=False, accumulate=4), ctx=gl,
                 profile=False)
    try:
        r.set_strands(sim)
        cam = r.default_camera(points=None)
        r.render_still(cam)                              # a paused simulation: its frames rebuilt, not moved
        assert r.frames_rendered == 5 and r.still_frames == 4
        sim.step()                                       # stepped, whether or not the renderer is told
        assert r.render(cam, refine=True).still == 0
        assert r.render(cam, refine=True).still == 1
        sim.step()
        r.strands_changed()
        assert r.render(cam, refine=True).still == 0
        sim.step()
        before = r.frames_rendered
        r.render_still(cam)
        assert r.frames_rendered - before == 5 and r.still_frames == 4
        assert r.render(cam, refine=True).still == 5 and r.still_frames == 4   # the mean kept
        for _ in range(3):                               # a simulation stepped every frame never is still
            sim.step()
            r.strands_changed()
            assert r.render(cam, refine=True).still == 0
    finally:
        r.release()
        sim.release()


def _error(a, b) -> float:
    return float(np.abs(a.astype(np.float64) - b).mean())


@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_the_still_mean_approaches_many_more_samples(gl, rasterizer):
    """Against 16 samples a pixel accumulated over 64 frames (1,024 a pixel), the mean of more
    frames at 4 samples comes closer and closer, to a third of one frame's distance at 64 frames
    (compute rasteriser, llvmpipe: 0.031, 0.025, 0.010 mean 8-bit error at 1, 16, 64 frames).
    While the moved frames widened a thin strand to a sample as one frame does, the compute
    rasteriser's mean at 4 samples stopped at 0.7x a frame's distance: the widening's blur."""
    size = (96, 72)
    ref = _renderer(gl, size=size, msaa=16, accumulate=64, rasterizer=rasterizer)
    try:
        cam = ref.default_camera()
        truth = ref.render_still(cam)
    finally:
        ref.release()
    err = {}
    for n in (1, 16, 64):
        r = _renderer(gl, size=size, msaa=4, accumulate=n, rasterizer=rasterizer)
        try:
            err[n] = _error(r.render_still(cam), truth)
            assert r.still_frames == (n if n > 1 else 0)
        finally:
            r.release()
    assert err[64] < err[16] < 0.9 * err[1] and err[64] < 0.5 * err[1], err


@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_a_still_pictures_frames_draw_their_own_finer_maps_once(gl, rasterizer):
    """The frames in a still picture's mean draw the shadow and opacity maps at
    still_shadow_map_size with still_dom_layers, through twins of the light-space passes, once
    for the picture; the first frame, the frames after the mean and moving frames keep the
    frames' own maps, which are not made again."""
    n = 3
    r = _renderer(gl, rasterizer=rasterizer, accumulate=n, still_shadow_map_size=512, still_segments=0)
    try:
        base = r.settings
        cam = r.default_camera()
        dom = r.get_pass("deep_opacity")
        own = dom.opacity
        seen = []
        for _ in range(n + 3):
            frame = r.render(cam, refine=True)
            assert r.settings is base
            t = frame.targets["dom"]
            seen.append((frame.still, t.size[0], "deep_opacity" in frame.kept))
        assert seen == [(0, 256, False), (1, 512, False), (2, 512, True), (3, 512, True), (4, 256, True), (5, 256, True)]
        assert dom.opacity is own and r.get_pass("deep_opacity") is dom
        still = r.still_settings()
        assert still.shadow_map_size == 512 and still.dom_layers == base.still_dom_layers
        assert r.still_settings() is still
        # what a still frame shades with is the twin's map and layers: the same frame drawn by a
        # renderer whose own maps are those
        twin = RenderSettings(**{**{f: getattr(base, f) for f in ("size", "strands_per_guide", "shadows", "draw_head",
                                                                   "rasterizer", "accumulate")},
                                 "shadow_map_size": 512, "dom_layers": base.still_dom_layers, "still_shadow_map_size": 0,
                                 "still_segments": 0})
        other = Renderer(twin, ctx=gl, profile=False)
        other.set_strands(wavy_groom(guides=6, points=8))
        try:
            for _ in range(2):
                other.render(cam, refine=True)
            r.render(cam.orbited(5.0), refine=True)   # start again
            r.render(cam, refine=True)
            r.render(cam, refine=True)
            np.testing.assert_allclose(_hdr(r.resolved_hdr(), base.size), _hdr(other.resolved_hdr(), base.size), atol=2e-3)
        finally:
            other.release()
    finally:
        r.release()


def test_still_maps_no_finer_than_the_frames_or_than_the_gpu_holds_are_the_frames_own(gl, monkeypatch):
    from mane.gpu import capabilities

    for kw in (dict(still_shadow_map_size=0), dict(still_shadow_map_size=256), dict(still_shadow_map_size=128)):
        for near in (False, True):   # the near field alone (still_near_field) changes no map
            r = _renderer(gl, still_segments=0, still_near_field=near, **kw)
            try:
                assert (r.still_settings() is r.settings) is not near
                assert r.still_settings().shading_options.get("near_field", False) is near
                cam = r.default_camera()
                for _ in range(3):
                    r.render(cam, refine=True)
                assert not r._still_twins
            finally:
                r.release()
    caps = capabilities.get_capabilities(gl)
    small = dict(caps.limits, max_shader_storage_block_size=1024 * 1024 * 16)   # a 1024 map's counters
    monkeypatch.setattr(capabilities, "get_capabilities", lambda ctx: type(caps)(**{**caps.__dict__, "limits": small}))
    r = _renderer(gl, still_shadow_map_size=8192, still_segments=0, still_extra_shadow_map_size=4096)
    try:
        assert r.still_settings().shadow_map_size == 1024
        assert r.still_settings().extra_shadow_map_size == 1024
    finally:
        r.release()


def test_the_extra_lights_maps_of_a_still_picture(gl):
    """A still picture's frames draw the extra lights' maps at still_extra_shadow_map_size (at most
    its light 0 map), the frames at extra_shadow_map_size (at most shadow_map_size)."""
    from mane.render.lights import default_lights

    r = _renderer(gl, still_segments=0, still_shadow_map_size=512, extra_shadow_map_size=64,
                  still_extra_shadow_map_size=1024, shadow_lights=4)
    try:
        assert r.still_settings().extra_shadow_map_size == 512
        cam, lights = r.default_camera(), default_lights()
        r.render(cam, lights, refine=True)
        frame_maps = [t.size for t in r.last_frame.targets["extra_doms"]]
        r.render(cam, lights, refine=True)
        still_maps = [t.size for t in r.last_frame.targets["extra_doms"]]
        assert frame_maps == [(64, 64)] * 2 and still_maps == [(512, 512)] * 2
    finally:
        r.release()
    r = _renderer(gl, still_segments=0, still_shadow_map_size=0, extra_shadow_map_size=64, still_extra_shadow_map_size=0,
                  still_near_field=False)
    try:
        assert r.still_settings() is r.settings
    finally:
        r.release()


def test_still_maps_that_do_not_fit_fall_back_to_the_frames_own(gl, monkeypatch):
    """A GPU out of memory for the finer maps (GPUMemoryError while their twins are made or
    drawn) gives the still picture the frames' own maps, not an error."""
    from mane.errors import GPUMemoryError
    from mane.render.passes.deep_opacity import DeepOpacityPass

    real = DeepOpacityPass.run

    def run(self, frame):
        if int(self.renderer.settings.shadow_map_size) == 512:
            raise GPUMemoryError("the deep opacity counters (512x512) do not fit (test)")
        return real(self, frame)

    monkeypatch.setattr(DeepOpacityPass, "run", run)
    r = _renderer(gl, accumulate=3, still_shadow_map_size=512)
    plain = _renderer(gl, accumulate=3, still_shadow_map_size=0, still_segments=0)
    try:
        cam = r.default_camera()
        got, want = r.render_still(cam), plain.render_still(cam)
        assert r.still_frames == 3 and r.still_settings() is r.settings and not r._still_twins
        assert np.array_equal(got, want)
    finally:
        r.release()
        plain.release()


@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_a_still_pictures_frames_draw_more_segments(gl, rasterizer):
    """still_segments: the frames in a still picture's mean expand the strands into more
    segments; such a frame equals one of a renderer whose own segments they are, and the frames
    after the mean are the frames' own again."""
    n = 3
    r = _renderer(gl, rasterizer=rasterizer, accumulate=n, still_shadow_map_size=0, still_segments=64)
    other = _renderer(gl, rasterizer=rasterizer, accumulate=n, still_shadow_map_size=0, still_segments=0, segments=64)
    plain = _renderer(gl, rasterizer=rasterizer, accumulate=n, still_shadow_map_size=0, still_segments=0)
    try:
        base = r.settings
        assert r.still_settings().segments == 64 and base.segments == 32
        cam = r.default_camera()
        for k in range(3):
            r.render(cam, refine=True)
            other.render(cam, refine=True)
            plain.render(cam, refine=True)
            assert r.settings is base
            if k == 2:   # a frame in the mean
                np.testing.assert_allclose(_hdr(r.resolved_hdr(), base.size), _hdr(other.resolved_hdr(), base.size),
                                           atol=2e-3)
                assert not np.allclose(_hdr(r.resolved_hdr(), base.size), _hdr(plain.resolved_hdr(), base.size),
                                       atol=2e-3)
        for _ in range(n):
            r.render(cam, refine=True)
            plain.render(cam, refine=True)
        np.testing.assert_allclose(_hdr(r.resolved_hdr(), base.size), _hdr(plain.resolved_hdr(), base.size), atol=2e-3)
    finally:
        for x in (r, other, plain):
            x.release()
