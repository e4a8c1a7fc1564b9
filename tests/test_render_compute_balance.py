"""The compute rasteriser's two scan-conversion forms (raster_segment.glsl, RASTER_BALANCE;
raster_segment.FORCED): one thread walking every sample column of its segment, and the
load-balanced form in which a work group shares its segments' columns. Atomic min and integer
add commute, so both must leave the per-sample buffers bit-identical (the coverage up to where
a sample saturates: assert_cover_equal): the same samples visited with the same depth and
coverage, whatever thread visits them. Scenes: thin strands widened to
a sample, wide close-up strands crossing many samples (some leaving the frame), segments in
every direction (steep, shallow, both ways), strands crossing the eye's plane (ends behind the
eye), ends just in front of it whose projections are huge (the RASTER_MAX_SPAN bound) and
segments longer than RASTER_MAX_STEPS columns, on one sample per pixel, 2 x 2 and 3 x 3. llvmpipe has no 64-bit atomics, so there this runs
the two-pass 32-bit path; a GPU with them runs VIS64. Also the deep opacity maps
(dom_raster.comp) and the OIT fill (oit_raster.comp) that include the same scan conversion."""
from __future__ import annotations

import numpy as np
import pytest

import mane.render.passes.depth_tiles as depth_tiles
import mane.render.passes.occlusion_tiles as occlusion_tiles
import mane.render.passes.raster_segment as raster_segment
from mane.errors import UsageError
from mane.groom import Groom
from mane.grooming.scene import default_scene
from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera

from test_render_compute_raster import saturated_cover
from test_render_tessellation import wavy_groom

pytestmark = pytest.mark.gpu


def star_groom() -> Groom:
    """Straight strands from near the origin in 24 directions of the image plane (every octant:
    steep and shallow, walked both ways) and four along the view axis through and past the eye
    at z = 1 (segments with an end behind the eye, and ends just in front of it)."""
    strands = []
    for k in range(24):
        a = 2 * np.pi * (k + 0.3) / 24
        t = np.linspace(0.0, 1.0, 7)[:, None]
        strands.append(np.c_[0.02 * np.cos(a) + 0.3 * t * np.cos(a), 0.02 * np.sin(a) + 0.3 * t * np.sin(a),
                             0.01 * np.sin(7 * t + k)])
    z = np.linspace(-0.2, 1.4, 9)[:, None]
    for dx, dy in ((0.0, 0.0), (0.004, 0.0), (0.0, -0.006), (0.03, 0.02)):
        strands.append(np.c_[np.full_like(z, dx), np.full_like(z, dy), z])
    return Groom.from_strands(strands)


def _capture(gl, form: int, monkeypatch, groom, head=None, camera=None, azimuth=25.0, distance_scale=1.0, **kw):
    """(the per-sample buffers after the raster pass, count_samples' statistics) with
    the form forced."""
    monkeypatch.setattr(raster_segment, "FORCED", form)
    # the same head and hair culls in both forms (by default the per-thread form culls no single
    # columns, nor by the hair), so that their statistics compare whole
    # (tests/test_render_compute_headcull.py, test_render_compute_haircull.py)
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", True)
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", True)
    s = RenderSettings(**{"size": (96, 72), "msaa": 1, "shadows": "none", "rasterizer": "compute",
                          "draw_head": head is not None, **kw})
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = camera or r.default_camera(azimuth, distance_scale=distance_scale, points=None)
        hc = r.get_pass("hair_compute")
        assert r.compute_raster
        hc.capture = True
        r.render(cam)
        bufs = {k: v.copy() for k, v in hc.captured.items()}
        stats = hc.count_samples(cam)
        stats["segments"] = r.get_pass("expand").segments
        return bufs, stats, hc.vis64
    finally:
        r.release()


def assert_cover_equal(a, b):
    """Coverage sums equal in fixed point, exactly, once clipped at COVER_SATURATED: a sample
    below it took every add (each add's check read less), so its sum is the order-free total;
    one that reached it stops taking adds, and how far past it it got depends on which adds
    passed the check together (the order of the atomics: run to run on a GPU, and between the
    two forms)."""
    sat = saturated_cover()
    np.testing.assert_array_equal(np.minimum(a, sat), np.minimum(b, sat))


SCENES = {
    # thin strands widened to one sample (coverage < 1), 1 and 2 x 2 samples per pixel
    "thin": lambda: (dict(groom=wavy_groom(), strands_per_guide=4, segments=20, width=0.0006, min_pixel_width=1.0),
                     (1, 4)),
    # wide strands at a close-up: tens of samples along and several across a segment
    "wide_closeup": lambda: (dict(groom=wavy_groom(), strands_per_guide=4, segments=8, width=0.02,
                                  min_pixel_width=0.0, distance_scale=0.35), (1, 4)),
    # head and hair at a close-up: partly off-screen, partly behind the head
    "head_closeup": lambda: (dict(zip(("groom", "head"), default_scene(num_guides=120, points=10, subdivisions=3)),
                                  strands_per_guide=3, width=0.004, size=(120, 90), distance_scale=0.3), (4,)),
    # every direction, and segments through the eye's plane
    "star_eye": lambda: (dict(groom=star_groom(), camera=Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0)),
                              width=0.003, segments=24), (1, 4)),
}


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_balanced_scan_conversion_is_bit_identical_to_per_thread(gl, monkeypatch, scene):
    kw, msaas = SCENES[scene]()
    for msaa in msaas:
        per_thread, stats0, vis64 = _capture(gl, 0, monkeypatch, msaa=msaa, **kw)
        balanced, stats1, _ = _capture(gl, 1, monkeypatch, msaa=msaa, **kw)
        hit = per_thread["ids"] >= 0
        assert hit.sum() > 100, (scene, msaa)   # the scene draws something
        np.testing.assert_array_equal(balanced["ids"], per_thread["ids"])
        assert_cover_equal(balanced["cover"], per_thread["cover"])
        assert stats1 == stats0, (scene, msaa)
        assert stats0["raster_atomic_bits"] == (64 if vis64 else 32)
        assert stats0["sample_visits"] >= stats0["sample_writes"] > 0
        if scene == "wide_closeup":   # many samples a segment: what the balance is for
            assert stats0["sample_visits"] > 20 * stats0["segments"]


def test_hostile_segments_are_bounded_in_both_forms(gl, monkeypatch):
    # ends just in front of the eye project far outside the frame and enormously wide: both
    # forms clamp the columns and the span, finish, and agree
    z = np.linspace(0.5, 0.99999, 5)[:, None]
    g = Groom.from_strands([np.c_[np.full_like(z, 0.001), np.full_like(z, 0.0007), z],
                            np.c_[np.full_like(z, -0.002), np.full_like(z, 0.001), z]])
    cam = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), near=1e-6)
    got = [_capture(gl, form, monkeypatch, g, camera=cam, width=0.05, segments=4) for form in (0, 1)]
    np.testing.assert_array_equal(got[0][0]["ids"], got[1][0]["ids"])
    assert_cover_equal(got[0][0]["cover"], got[1][0]["cover"])
    assert got[0][1] == got[1][1] and got[0][1]["sample_visits"] > 0


def test_columns_past_raster_max_steps_are_cut_in_both_forms(gl, monkeypatch):
    # two horizontal one-segment strands across a 4096 x 8 frame at 3 x 3 samples a pixel
    # (12288 sample columns, the segments wider still): each is cut to RASTER_MAX_STEPS + 1
    # columns from the frame's left edge, one sample each (widened to one sample: h = 0.5)
    import re
    from pathlib import Path

    text = Path(raster_segment.__file__).with_suffix(".glsl").read_text()
    steps = int(re.search(r"#define RASTER_MAX_STEPS (\d+)", text)[1])
    x = np.array([[-150.0], [150.0]])
    g = Groom.from_strands([np.c_[x, np.zeros_like(x), np.zeros_like(x)], np.c_[x, np.full_like(x, 0.02), 0 * x]])
    cam = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0))
    assert 12288 > steps + 1
    for form in (0, 1):
        bufs, stats, _ = _capture(gl, form, monkeypatch, g, camera=cam, size=(4096, 8), msaa=8, width=0.0006,
                                  segments=1, strands_per_guide=1)
        assert stats["segments"] == 2
        assert stats["sample_visits"] == 2 * (steps + 1), form
        hit = bufs["ids"] >= 0
        assert hit.sum() == 2 * (steps + 1)
        assert hit[:, :steps + 1].any(axis=0).all() and not hit[:, steps + 1:].any()


def test_deep_opacity_maps_are_bit_identical(gl, monkeypatch):
    groom, head = default_scene(num_guides=150, points=12, subdivisions=3)
    maps = []
    for form in (0, 1):
        monkeypatch.setattr(raster_segment, "FORCED", form)
        r = Renderer(RenderSettings(size=(96, 72), msaa=1, rasterizer="compute", shadows="deep_opacity",
                                    shadow_map_size=128, strands_per_guide=4), ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(head)
            r.render(r.default_camera(25.0))
            maps.append(r.get_pass("deep_opacity").read())
        finally:
            r.release()
    assert (maps[0][..., 3] < 1e8).sum() > 500
    np.testing.assert_array_equal(maps[0], maps[1])


def test_oit_fill_is_the_same_in_both_forms(gl, monkeypatch):
    # every fragment (the OIT capture: pixel, depth, segment, colour) and the K-buffer's kept
    # depths (the K smallest per pixel: independent of the order of the atomics)
    from tests.test_oit_methods import CAM, LIGHTS, curtain_groom, sphere

    got = []
    for form in (0, 1):
        monkeypatch.setattr(raster_segment, "FORCED", form)
        r = Renderer(RenderSettings(size=(96, 72), msaa=1, rasterizer="compute", oit="k_buffer", oit_k=4,
                                    shadows="none"), ctx=gl, profile=False)
        try:
            r.set_strands(curtain_groom())
            r.set_head(sphere())
            m = r.get_pass("oit").current()
            m.capture, m.reset = True, False
            r.render(CAM, LIGHTS)
            f = m.captured
            order = np.lexsort((f["segment"], f["window_z"].view(np.uint32), f["pixel"]))
            got.append(({k: np.asarray(v)[order] for k, v in f.items() if k != "size"},
                        m.read_slots()["zbits"]))
        finally:
            r.release()
    (f0, z0), (f1, z1) = got
    assert len(f0["pixel"]) > 500
    for k in f0:
        np.testing.assert_array_equal(f0[k], f1[k], err_msg=k)
    np.testing.assert_array_equal(z0, z1)


def test_raster_balance_by_renderer_and_environment(gl, monkeypatch):
    from mane.gpu.context import is_software_renderer

    monkeypatch.setenv("MANE_RASTER_BALANCE", "0")
    assert raster_segment._balance_from_env() == 0
    monkeypatch.setenv("MANE_RASTER_BALANCE", "1")
    assert raster_segment._balance_from_env() == 1
    monkeypatch.delenv("MANE_RASTER_BALANCE")
    assert raster_segment._balance_from_env() is None   # unset: by the renderer
    monkeypatch.setenv("MANE_RASTER_BALANCE", "yes")
    with pytest.raises(UsageError, match="MANE_RASTER_BALANCE"):
        raster_segment._balance_from_env()
    monkeypatch.setattr(raster_segment, "FORCED", None)
    # balanced on GPUs, one thread a segment on CPU rasterisers (llvmpipe: 3-4x faster there)
    assert raster_segment.raster_defines(gl) == {"RASTER_BALANCE": 0 if is_software_renderer(gl) else 1}
    monkeypatch.setattr(raster_segment, "FORCED", 1)
    assert raster_segment.raster_defines(gl) == {"RASTER_BALANCE": 1}
