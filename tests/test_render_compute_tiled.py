"""The compute rasteriser's tiled scan conversion (raster_segment.FORCED = 2; passes/raster_tiles.py,
raster_tiles.glsl): the segments binned to 16 x 16-sample screen tiles (raster_tiles.TILE_SHIFT), each tile's samples
visited in shared memory. Its per-sample buffers must be bit-identical to the per-thread and
balanced forms' (ids exactly, the coverage up to where a sample saturates: assert_cover_equal),
with the same samples visited (count_samples' ``sample_visits``; its culls are its own), on:
dense curtains of strands across tile borders, long segments across many tiles, steep and
shallow segments both ways, segments off screen and through the eye's plane, heads in front of
and behind the hair (head cull), the hair cull's depth split, 1, 2 x 2 and 4 x 4 samples a
pixel, hostile segments (RASTER_MAX_SPAN, RASTER_MAX_STEPS), and lists that overflow their
storage (the balanced form runs that step instead; one step overflowing and the other not).
The renderer's images are identical too. llvmpipe has no 64-bit atomics: this runs the 32-bit
path (walk 2 the id pass); a GPU with them runs VIS64."""
from __future__ import annotations

import numpy as np
import pytest

import mane.render.passes.depth_tiles as depth_tiles
import mane.render.passes.occlusion_tiles as occlusion_tiles
import mane.render.passes.raster_segment as raster_segment
import mane.render.passes.raster_tiles as raster_tiles
from mane.groom import Groom
from mane.grooming.scene import default_scene
from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera

from test_oit_methods import CAM, LIGHTS, curtain_groom, sphere
from test_render_compute_balance import assert_cover_equal, star_groom
from test_render_compute_headcull import needles_groom
from test_render_compute_raster import saturated_cover
from test_render_tessellation import wavy_groom

pytestmark = pytest.mark.gpu
TILED = raster_segment.TILED


def _capture(gl, monkeypatch, form, groom, head=None, camera=None, hair_cull=None, azimuth=25.0,
             distance_scale=1.0, image=False, steps=None, **kw):
    """(captured buffers, count_samples' statistics, the image or None) with the form forced;
    ``steps``: a list the tiled steps' list status is appended to (after each scan)."""
    monkeypatch.setattr(raster_segment, "FORCED", form)
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", True)
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", hair_cull)
    s = RenderSettings(**{"size": (96, 72), "msaa": 1, "shadows": "none", "rasterizer": "compute",
                          "draw_head": head is not None, **kw})
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = camera or r.default_camera(azimuth, distance_scale=distance_scale, points=None)
        hc = r.get_pass("hair_compute")
        assert r.compute_raster
        if steps is not None:
            scan = hc.raster_tiles.scan

            def scan_and_record(groups):
                scan(groups)
                steps.append(hc.raster_tiles.status())
            monkeypatch.setattr(hc.raster_tiles, "scan", scan_and_record)
        hc.capture = True
        r.render(cam, LIGHTS)
        bufs = {k: v.copy() for k, v in hc.captured.items()}
        img = r.render_image(cam, LIGHTS) if image else None
        stats = hc.count_samples(cam, LIGHTS)
        return bufs, stats, img
    finally:
        r.release()


def long_groom() -> Groom:
    """One-segment strands across the whole frame in 12 directions (shallow, steep, diagonal,
    both ways), offset so that they cross tile corners and edges at every phase."""
    strands = []
    for k in range(12):
        a = np.pi * k / 12 + 0.05
        c = np.array([0.013 * k - 0.07, 0.011 * (k % 5) - 0.02, 0.002 * k])
        d = np.array([np.cos(a), np.sin(a), 0.3 * np.sin(3 * a)]) * 0.25
        strands.append(np.stack([c - d, c + d]))
    return Groom.from_strands(strands)


SCENES = {
    # a curtain of wide strands from the front: many layers across every tile border
    "curtain": lambda: dict(groom=curtain_groom(n=300), strands_per_guide=4, width=0.01, camera=CAM),
    # and a ball through it: hair in front of and behind the head
    "curtain_ball": lambda: dict(groom=curtain_groom(n=300), head=sphere(0.04, (0.03, -0.02, 0.0)),
                                 strands_per_guide=4, width=0.01, camera=CAM),
    # long slanted strands from in front of a ball to behind it (across the split depth)
    "needles": lambda: dict(groom=needles_groom(400), head=sphere(0.04, (0.0, 0.0, 0.0)), segments=3,
                            strands_per_guide=1, width=0.02, camera=CAM),
    # one segment a strand across the frame: tens of tiles each, every direction
    "long": lambda: dict(groom=long_groom(), segments=1, strands_per_guide=1, width=0.004,
                         camera=Camera(eye=(0.0, 0.0, 0.6), target=(0.0, 0.0, 0.0))),
    # a head close-up: partly off screen, partly behind the head (head cull)
    "head_closeup": lambda: dict(zip(("groom", "head"), default_scene(num_guides=120, points=10, subdivisions=3)),
                                 strands_per_guide=3, width=0.004, size=(120, 90), distance_scale=0.3),
    # every direction, and segments through the eye's plane; thin strands widened to a sample
    "star_eye": lambda: dict(groom=star_groom(), camera=Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0)),
                             width=0.003, segments=24),
    "thin": lambda: dict(groom=wavy_groom(), strands_per_guide=4, segments=20, width=0.0006, min_pixel_width=1.0),
}
CASES = [("curtain", 1, None), ("curtain", 4, None), ("curtain", 16, None), ("curtain_ball", 4, None),
         ("curtain_ball", 16, False), ("needles", 4, None), ("long", 1, None), ("long", 4, False),
         ("head_closeup", 4, None), ("star_eye", 4, None), ("thin", 1, False)]


@pytest.mark.parametrize("scene,msaa,hair_cull", CASES)
def test_tiled_is_bit_identical_to_the_other_forms(gl, monkeypatch, scene, msaa, hair_cull):
    kw = SCENES[scene]()
    got = {form: _capture(gl, monkeypatch, form, msaa=msaa, hair_cull=hair_cull, **kw) for form in (TILED, 1, 0)}
    tiled, s_tiled, _ = got[TILED]
    hit = tiled["ids"] >= 0
    assert hit.sum() > 100, scene   # the scene draws something
    for form in (0, 1):
        bufs, stats, _ = got[form]
        np.testing.assert_array_equal(tiled["ids"], bufs["ids"], err_msg=f"{scene} form {form}")
        assert_cover_equal(tiled["cover"], bufs["cover"])
        assert s_tiled["sample_visits"] == stats["sample_visits"], (scene, form)
    assert s_tiled["sample_writes"] + s_tiled["sample_culled"] >= got[1][1]["sample_writes"]
    if scene.startswith("curtain"):   # the tile's own bounds skip visits in saturated hair
        assert (tiled["cover"] >= saturated_cover()).sum() > 0.2 * hit.sum()
        assert s_tiled["sample_culled"] > got[0][1]["sample_culled"]


def test_renderer_images_are_identical(gl, monkeypatch):
    kw = SCENES["head_closeup"]()
    imgs = [_capture(gl, monkeypatch, form, msaa=4, image=True, **kw)[2] for form in (TILED, 1)]
    assert imgs[0].std() > 0.01
    np.testing.assert_array_equal(imgs[0], imgs[1])


def test_hostile_segments_are_bounded(gl, monkeypatch):
    # ends just in front of the eye: projected far outside the frame, enormously wide (the bin
    # takes every row of their strips); the same samples as the other forms
    z = np.linspace(0.5, 0.99999, 5)[:, None]
    g = Groom.from_strands([np.c_[np.full_like(z, 0.001), np.full_like(z, 0.0007), z],
                            np.c_[np.full_like(z, -0.002), np.full_like(z, 0.001), z]])
    cam = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), near=1e-6)
    got = [_capture(gl, monkeypatch, form, g, camera=cam, width=0.05, segments=4) for form in (TILED, 1)]
    np.testing.assert_array_equal(got[0][0]["ids"], got[1][0]["ids"])
    assert_cover_equal(got[0][0]["cover"], got[1][0]["cover"])
    assert got[0][1]["sample_visits"] == got[1][1]["sample_visits"] > 0


def test_columns_past_raster_max_steps_are_cut(gl, monkeypatch):
    # a 4096 x 8 frame at 3 x 3 samples a pixel: two segments across it, each cut to
    # RASTER_MAX_STEPS + 1 columns (257 tiles of columns), as in the other forms
    x = np.array([[-150.0], [150.0]])
    g = Groom.from_strands([np.c_[x, np.zeros_like(x), np.zeros_like(x)], np.c_[x, np.full_like(x, 0.02), 0 * x]])
    cam = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0))
    got = [_capture(gl, monkeypatch, form, g, camera=cam, size=(4096, 8), msaa=8, width=0.0006, segments=1,
                    strands_per_guide=1) for form in (TILED, 1)]
    np.testing.assert_array_equal(got[0][0]["ids"], got[1][0]["ids"])
    assert got[0][1]["sample_visits"] == got[1][1]["sample_visits"] > 8000


@pytest.mark.parametrize("hair_cull", (False, True))
def test_overflowing_lists_fall_back_exactly(gl, monkeypatch, hair_cull):
    kw = SCENES["curtain_ball"]()
    ref, s_ref, _ = _capture(gl, monkeypatch, 1, msaa=4, hair_cull=hair_cull, **kw)
    steps = []
    _capture(gl, monkeypatch, TILED, msaa=4, hair_cull=hair_cull, steps=steps, **kw)
    totals = [s["total"] for s in steps[:len(steps) // 2]]   # the first frame's steps (then count_samples')
    assert len(totals) == (2 if hair_cull else 1) and not any(s["overflow"] for s in steps)
    # every step overflowing; with the split, one step overflowing and the other not (the
    # 32-bit path's ids then set by the balanced form after the tiled step, or before it)
    capacities = [1] + ([min(totals)] if hair_cull else [])
    if hair_cull:
        assert totals[0] != totals[1]
    for cap in capacities:
        monkeypatch.setattr(raster_tiles, "CAPACITY", cap)
        steps = []
        bufs, stats, _ = _capture(gl, monkeypatch, TILED, msaa=4, hair_cull=hair_cull, steps=steps, **kw)
        flags = [s["overflow"] for s in steps[:len(totals)]]
        assert flags == [t > cap for t in totals] and any(flags)
        np.testing.assert_array_equal(bufs["ids"], ref["ids"])
        assert_cover_equal(bufs["cover"], ref["cover"])
        # (an overflowed step's culled segments counted by its bin and again by the balanced form)
        assert stats["sample_visits"] >= s_ref["sample_visits"]


def test_the_lists_grow_past_the_largest_total(gl, monkeypatch):
    """Lists too small for the frame overflow (the balanced form draws the step) until a copy of
    the largest total, read once the GPU is past it, grows them; then no step overflows."""
    kw = SCENES["curtain_ball"]()
    monkeypatch.setattr(raster_tiles, "ENTRIES_PER_SEGMENT", 0)   # the first capacity: a tile's worth
    monkeypatch.setattr(raster_tiles, "MIN_CAPACITY", 1)
    monkeypatch.setattr(raster_tiles, "CHECK_EVERY", 2)
    monkeypatch.setattr(raster_segment, "FORCED", TILED)
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", False)
    s = RenderSettings(**{"size": (96, 72), "msaa": 4, "shadows": "none", "rasterizer": "compute",
                          "draw_head": kw.get("head") is not None,
                          **{k: v for k, v in kw.items() if k not in ("groom", "head", "camera")}})
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(kw["groom"])
        r.set_head(kw.get("head"))
        cam = kw.get("camera") or r.default_camera(25.0, points=None)
        rt = r.get_pass("hair_compute").raster_tiles
        seen = []
        for _ in range(12):
            r.render(cam, LIGHTS)
            seen.append((rt.capacity, rt.status()))
        first, last = seen[0], seen[-1]
        assert first[1]["overflow"] and first[1]["total"] > first[0]
        assert not last[1]["overflow"] and last[0] >= last[1]["peak"] >= first[1]["total"]
        assert last[0] <= int(raster_tiles.GROWTH * last[1]["peak"]) + 1   # grown to the rule, no further
    finally:
        r.release()


def test_the_form_by_environment_and_site(gl, monkeypatch):
    from mane.errors import UsageError

    for v, form in (("2", TILED), ("tiled", TILED), ("balanced", 1), ("per_thread", 0)):
        monkeypatch.setenv("MANE_RASTER_BALANCE", v)
        assert raster_segment._balance_from_env() == form
    monkeypatch.setenv("MANE_RASTER_BALANCE", "3")
    with pytest.raises(UsageError, match="MANE_RASTER_BALANCE"):
        raster_segment._balance_from_env()
    # forced tiled: the hair site's form; the two-form sites (deep opacity, OIT) take the balanced one
    monkeypatch.setattr(raster_segment, "FORCED", TILED)
    assert raster_segment.form_for(gl, 3) == TILED
    assert raster_segment.balance_for(gl) == 1 and raster_segment.raster_defines(gl) == {"RASTER_BALANCE": 1}
    assert raster_segment.raster_defines(gl, TILED) == {"RASTER_BALANCE": TILED}
    with pytest.raises(ValueError):
        raster_segment.raster_defines(gl, 3)


@pytest.mark.parametrize("block", [raster_tiles.SCAN_BLOCK, 256])
def test_the_lists_scan_is_numpys_over_many_blocks(gl, monkeypatch, block):
    """raster_tiles_scan.comp's three dispatches against NumPy: the offsets (an exclusive cumsum),
    the scatter's cursors, the non-empty tiles in order, the total, the dispatches and the counts
    zeroed, over 1.2M tiles (1,172 blocks of 1,024: more blocks than the middle dispatch's work
    group has threads), with and without overflow; saturating sums past 2^30."""
    monkeypatch.setattr(raster_tiles, "SCAN_BLOCK", block)
    rng = np.random.default_rng(7)
    rt = raster_tiles.RasterTiles(gl)
    side = 1 << raster_tiles.TILE_SHIFT
    n = 1200 * 1000
    index_words = raster_tiles.INDEX["RT_HEADER"]
    try:
        for counts, capacity in ((rng.integers(0, 40, n) * (rng.random(n) < 0.3), 1 << 24),
                                 (rng.integers(0, 40, n) * (rng.random(n) < 0.3), 1000),
                                 (np.where(np.arange(n) % 97 == 0, 0x7FFFFFFF, 1), 1 << 24)):
            monkeypatch.setattr(raster_tiles, "CAPACITY", capacity)
            rt.prepare((1200 * side, 1000 * side - 3), 10)
            assert rt.tiles == (1200, 1000) and rt.capacity == capacity
            counts = counts.astype(np.uint32)
            rt.counts.write(counts.tobytes())
            rt.scan((17, 3))
            c = np.minimum(counts.astype(np.int64), 1 << 30)
            total = min(int(c.sum()), 1 << 30)
            offsets = np.minimum(np.concatenate([[0], np.cumsum(c)[:-1]]), 1 << 30)
            index = np.frombuffer(rt.index.read(), np.uint32)
            after = np.frombuffer(rt.counts.read(), np.uint32)
            np.testing.assert_array_equal(index[index_words:index_words + n], offsets)
            assert index[index_words + n] == total
            filled = np.flatnonzero(counts)
            np.testing.assert_array_equal(index[index_words + n + 1:index_words + n + 1 + len(filled)], filled)
            np.testing.assert_array_equal(after[n:2 * n], offsets)
            assert not after[:n].any()
            overflow = total > capacity
            assert index[raster_tiles.INDEX["RT_OVERFLOW"]] == int(overflow)
            assert index[raster_tiles.INDEX["RT_TOTAL"]] == total
            args = index[raster_tiles.INDEX["RT_TILED_ARGS"]:raster_tiles.INDEX["RT_TILED_ARGS"] + 3]
            fallback = index[raster_tiles.INDEX["RT_FALLBACK_ARGS"]:raster_tiles.INDEX["RT_FALLBACK_ARGS"] + 3]
            assert list(args) == [0 if overflow else len(filled), 1, 1]
            assert list(fallback) == ([17, 3, 1] if overflow else [0, 1, 1])
    finally:
        rt.release()


@pytest.mark.parametrize("sub, want", [
    ({"size": 32, "stages": 0xFF, "features": 0xFF}, True),    # NVIDIA
    ({"size": 8, "stages": 0x20, "features": 0x5}, True),
    ({"size": 4, "stages": 0xFF, "features": 0xFF}, False),    # smaller than RT_MIN_SUBGROUP
    ({"size": 24, "stages": 0xFF, "features": 0xFF}, False),   # not a power of two
    ({"size": 32, "stages": 0x10, "features": 0xFF}, False),   # no compute stage
    ({"size": 32, "stages": 0xFF, "features": 0x1}, False),    # no arithmetic
    ({}, False),                                               # no GL_KHR_shader_subgroup
])
def test_the_subgroup_scan_where_subgroups_fit(monkeypatch, sub, want):
    """The column scans by subgroup operations (the tiled walk's RT_SUBGROUP, the balanced form's
    RASTER_SUBGROUP) only where their assumptions hold; where they run (GPUs), the bit-identity
    tests above and in test_render_compute_balance.py run them."""
    class Caps:
        subgroup = sub

    monkeypatch.setattr(raster_segment, "get_capabilities", lambda ctx: Caps())
    assert raster_segment.subgroup_scan(object()) is want
    assert raster_tiles.defines(object())["RT_SUBGROUP"] == int(want)
    assert raster_tiles.defines()["RT_SUBGROUP"] == 0
    assert raster_segment.subgroup_defines(object(), 1) == {"RASTER_SUBGROUP": int(want)}
    assert raster_segment.subgroup_defines(object(), 0) == {"RASTER_SUBGROUP": 0}
    monkeypatch.setattr(raster_segment, "SUBGROUP_SCAN", False)
    assert raster_segment.subgroup_scan(object()) is False
