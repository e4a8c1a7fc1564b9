"""The compute rasteriser's hair self-occlusion cull (passes/occlusion_tiles.py): the segments
are scan-converted in two dispatches, those whose nearest window depth lies in front of a split
depth first; then a tile map of, per sample, min(head depth, the next float past the nearest
hair's depth where the sample's coverage has saturated) reduced by max over tiles; then the rest
against it (raster_segment.glsl's RASTER_CULL: a column at or past every tile it touches). A
visit culled there would fail the head test or lose the depth min (strictly further than the
sample's nearest depth, which only falls) and skip the saturated coverage, so the per-sample
buffers must be bit-identical with the cull on and off (ids exactly, the coverage up to where a
sample saturates: assert_cover_equal), with and without a head, at 1, 2 x 2 and 4 x 4 samples a
pixel, in both scan-conversion forms. On llvmpipe (no 64-bit atomics) this runs the 32-bit
path, whose id pass uses the same map. The map is checked against a NumPy twin of known
buffers, and the cull must skip samples in dense hair and none where nothing saturates."""
from __future__ import annotations

import numpy as np
import pytest

import mane.render.passes.depth_tiles as depth_tiles
import mane.render.passes.occlusion_tiles as occlusion_tiles
import mane.render.passes.raster_segment as raster_segment
from mane.render import Renderer, RenderSettings

from test_oit_methods import CAM, LIGHTS, curtain_groom, sphere
from test_render_compute_balance import assert_cover_equal
from test_render_compute_headcull import max_pool, needles_groom, render_capture
from test_render_compute_raster import saturated_cover

pytestmark = pytest.mark.gpu


def _render(gl, monkeypatch, cull, groom, head=None, camera=None, form=None, **kw):
    """(captured buffers, count_samples' statistics) with the hair cull forced on or off."""
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", cull)
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", True)   # the same head cull either way
    if form is not None:
        monkeypatch.setattr(raster_segment, "FORCED", form)
    s = RenderSettings(**{"size": (96, 72), "msaa": 1, "shadows": "none", "rasterizer": "compute",
                          "draw_head": head is not None, "strands_per_guide": 3, "width": 0.006, **kw})
    bufs, stats, _ = render_capture(gl, s, groom, head, camera or CAM)
    return bufs, stats


SCENES = {
    # a curtain of wide strands seen from the front: many layers, most samples saturated
    "curtain": lambda: dict(groom=curtain_groom(n=300), strands_per_guide=4, width=0.01),
    # and a ball through it (partly in front of the hair, partly behind)
    "curtain_ball": lambda: dict(groom=curtain_groom(n=300), head=sphere(0.04, (0.03, -0.02, 0.0)),
                                 strands_per_guide=4, width=0.01),
    # strands from in front of a ball to behind it, slanted: long segments across the split depth
    "needles": lambda: dict(groom=needles_groom(400), head=sphere(0.04, (0.0, 0.0, 0.0)), segments=3,
                            strands_per_guide=1, width=0.02),
}
CASES = [("curtain", 1), ("curtain", 4), ("curtain", 16), ("curtain_ball", 1), ("curtain_ball", 4),
         ("curtain_ball", 16), ("needles", 1), ("needles", 4)]


@pytest.mark.parametrize("scene,msaa", CASES)
def test_hair_cull_is_bit_identical(gl, monkeypatch, scene, msaa):
    kw = SCENES[scene]()
    off, s_off = _render(gl, monkeypatch, False, msaa=msaa, **kw)
    on, s_on = _render(gl, monkeypatch, True, msaa=msaa, **kw)
    hit = off["ids"] >= 0
    assert hit.sum() > 500
    assert (off["cover"] >= saturated_cover()).sum() > 0.2 * hit.sum()   # the scene saturates
    np.testing.assert_array_equal(on["ids"], off["ids"])
    assert_cover_equal(on["cover"], off["cover"])
    # the same samples visited; culled ones counted among them
    assert s_on["sample_visits"] == s_off["sample_visits"]
    assert s_on["sample_culled"] > s_off["sample_culled"]
    # writes: the visits in front of the head, less those culled
    assert s_on["sample_writes"] <= s_off["sample_writes"] <= s_on["sample_writes"] + s_on["sample_culled"]


@pytest.mark.parametrize("form", (0, 1))
@pytest.mark.parametrize("scene", ("curtain_ball", "needles"))
def test_hair_cull_in_both_scan_conversion_forms(gl, monkeypatch, form, scene):
    kw = SCENES[scene]()
    off, s_off = _render(gl, monkeypatch, False, form=form, msaa=4, **kw)
    on, s_on = _render(gl, monkeypatch, True, form=form, msaa=4, **kw)
    np.testing.assert_array_equal(on["ids"], off["ids"])
    assert_cover_equal(on["cover"], off["cover"])
    assert s_on["sample_visits"] == s_off["sample_visits"] and s_on["sample_culled"] > s_off["sample_culled"]


def test_dense_hair_without_a_head_culls_many_visits(gl, monkeypatch):
    # no head: nothing is culled but by the hair; in front of the curtain's saturated samples most
    # of the far part's visits are no-ops, which the cull skips
    off, s_off = _render(gl, monkeypatch, False, msaa=4, **SCENES["curtain"]())
    on, s_on = _render(gl, monkeypatch, True, msaa=4, **SCENES["curtain"]())
    assert s_off["sample_culled"] == 0
    assert s_on["sample_culled"] > 0.2 * s_on["sample_visits"], s_on


def test_nothing_saturated_culls_nothing(gl, monkeypatch):
    # a few thin strands apart (a sample a strand at coverage < 1): no sample saturates
    bufs, stats = _render(gl, monkeypatch, True, curtain_groom(n=6), msaa=4, width=0.0004, min_pixel_width=1.0,
                          strands_per_guide=1)
    assert (bufs["ids"] >= 0).sum() > 100
    assert bufs["cover"].max() < saturated_cover()
    assert stats["sample_culled"] == 0 and stats["sample_visits"] > 0


def test_the_occlusion_map_of_known_buffers(gl):
    # known per-sample buffers (32-bit form: depth bits, coverage) and a known head depth at
    # 21 x 11 pixels, 1 to 4 x 4 samples a pixel (at 3 x 3 tile edges cut pixels); the map's twin in NumPy: per sample
    # min(head, saturated ? next float past the hair's depth : 1), max over tiles
    from mane.render.passes.hair_compute import COVER_SCALE
    from mane.render.passes.occlusion_tiles import OcclusionTiles

    rng = np.random.default_rng(9)
    w, h = 21, 11
    head = rng.uniform(0.3, 0.9, (h, w)).astype(np.float32)
    head[:, :3] = 1.0   # background
    tex = gl.depth_texture((w, h), data=head.tobytes())
    sat = int(round(saturated_cover() * COVER_SCALE))
    t = OcclusionTiles(gl)
    try:
        for grid, side in ((1, 8), (2, 16), (3, 32), (4, 32)):
            sh, sw = h * grid, w * grid
            hair = rng.uniform(0.1, 0.95, (sh, sw)).astype(np.float32)
            dbits = hair.view(np.uint32).copy()
            dbits[rng.random((sh, sw)) < 0.1] = 0xFFFFFFFF   # no hair
            cover = rng.integers(sat - 3, sat + 3, (sh, sw)).astype(np.uint32)
            cover[dbits == 0xFFFFFFFF] = 0

            def pixel_major(a):   # rows of samples -> hair_vis.glsl's sample_index order
                return a.reshape(h, grid, w, grid).transpose(0, 2, 1, 3).reshape(-1)

            vis = gl.buffer(pixel_major(dbits).tobytes())
            cov = gl.buffer(pixel_major(cover).tobytes())
            try:
                t.update(tex, grid, vis, cov, vis64=False)
                nxt = np.where(dbits == 0xFFFFFFFF, np.uint32(0x3F800000), dbits + np.uint32(1)).view(np.float32)
                per = np.minimum(np.kron(head, np.ones((grid, grid), np.float32)),
                                 np.where(cover >= sat, nxt, np.float32(1.0)))
                want = max_pool(per, side)
                got = t.read()
                assert got.shape == want.shape
                # the head's 24-bit depth read back apart from the shader's fetch: within a step
                np.testing.assert_allclose(got, want, rtol=0, atol=2.0 ** -24)
                assert (got < 1.0).any() and (got == 1.0).any()
            finally:
                vis.release()
                cov.release()
    finally:
        t.release()
        tex.release()


def test_the_cull_by_renderer_and_a_bad_switch(gl, monkeypatch):
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", None)
    for form in (0, 1):
        monkeypatch.setattr(raster_segment, "FORCED", form)
        assert occlusion_tiles.hair_cull(gl) == bool(form or occlusion_tiles.PER_THREAD)
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", "yes")
    with pytest.raises(ValueError, match="HAIR_CULL"):
        occlusion_tiles.hair_cull(gl)


def test_the_split_depth_lies_in_the_hair(gl):
    # SPLIT of the way through the hair's padded view-depth range, as a window depth
    r = Renderer(RenderSettings(size=(64, 48), shadows="none", rasterizer="compute", draw_head=False), ctx=gl,
                 profile=False)
    try:
        r.set_strands(curtain_groom())
        frame_view = r.camera_view(CAM)
        z = occlusion_tiles.split_depth(r, frame_view)
        lo, hi = r.hair_bbox()
        pad = r.strand_pad() + float(r.settings.width)
        corners = np.array([[x, y, zz] for x in (lo[0] - pad, hi[0] + pad) for y in (lo[1] - pad, hi[1] + pad)
                            for zz in (lo[2] - pad, hi[2] + pad)])
        d = (corners - frame_view.eye) @ np.asarray(frame_view.forward, float)
        dist = d.min() + occlusion_tiles.SPLIT * (d.max() - d.min())
        p = np.r_[frame_view.eye + dist * np.asarray(frame_view.forward, float), 1.0]
        c = np.asarray(frame_view.view_proj, float) @ p
        assert 0.0 < z < 1.0
        assert z == pytest.approx(c[2] / c[3] * 0.5 + 0.5, abs=1e-6)
    finally:
        r.release()


def test_the_split_depth_kept_on_the_view_follows_the_hair_and_split(gl, monkeypatch):
    """split_depth keeps its value on the camera's View: a new groom (another box) or another
    SPLIT gives what a fresh computation gives."""
    r = Renderer(RenderSettings(size=(64, 48), shadows="none", rasterizer="compute", draw_head=False), ctx=gl,
                 profile=False)
    try:
        groom = curtain_groom()
        r.set_strands(groom)
        view = r.camera_view(CAM)
        first = occlusion_tiles.split_depth(r, view)
        assert occlusion_tiles.split_depth(r, view) == first
        r.set_strands(groom.translated((0.0, 0.0, 0.05)))   # nearer the camera: another split
        box = r.hair_bbox()
        pad = r.strand_pad() + float(r.settings.width)
        nearer = occlusion_tiles.split_depth(r, view)
        assert nearer == occlusion_tiles._split_depth(box, pad, view) and nearer != first
        monkeypatch.setattr(occlusion_tiles, "SPLIT", 0.6)
        deeper = occlusion_tiles.split_depth(r, view)
        assert deeper == occlusion_tiles._split_depth(box, pad, view) and deeper != first
    finally:
        r.release()
