"""The compute rasteriser's head culling (passes/depth_tiles.py): a per-frame tile map of the
head's depth (the max over tiles of about TILE x TILE pixels), and the segments (by their
bounding box and nearest depth) and sample columns at or behind it skipped whole
(raster_segment.glsl's RASTER_CULL). Every skipped sample would have failed its own `z >= scene
depth` test, so the per-sample buffers must be bit-identical with the cull on and off (the
coverage up to where a sample saturates: assert_cover_equal), on heads in front of, behind,
partly covering and pierced by the hair, at 1, 2 x 2 and 4 x 4 samples a pixel, the head drawn
with one sample and multisampled (head_msaa: the resolved depth). The map is checked against a
NumPy max-pool of the read-back depth texture, and the cull must actually skip samples where
hair lies behind the head, and none where there is no head. Also the OIT fill (oit_raster.comp),
which makes the same test at a fragment."""
from __future__ import annotations

import numpy as np
import pytest

import mane.render.passes.depth_tiles as depth_tiles
import mane.render.passes.occlusion_tiles as occlusion_tiles
import mane.render.passes.raster_segment as raster_segment
from mane.groom import Groom
from mane.grooming.scene import default_scene
from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera
from mane.render.passes.hair_compute import sample_grid

from test_oit_methods import CAM, LIGHTS, curtain_groom, sphere
from test_render_compute_balance import assert_cover_equal, star_groom

pytestmark = pytest.mark.gpu


def render_capture(gl, settings, groom, head, camera=None, extra=None):
    """One compute-rasteriser frame: (its captured per-sample buffers, count_samples' statistics,
    ``extra(renderer)`` read before those statistics or None); the camera by default the
    renderer's default view."""
    r = Renderer(settings, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = camera or r.default_camera(25.0, points=None)
        hc = r.get_pass("hair_compute")
        assert r.compute_raster
        hc.capture = True
        r.render(cam, LIGHTS)
        bufs = {k: v.copy() for k, v in hc.captured.items()}
        more = extra(r) if extra is not None else None
        return bufs, hc.count_samples(cam, LIGHTS), more
    finally:
        r.release()


def _render(gl, monkeypatch, cull: bool, groom, head, camera=None, form=None, **kw):
    """(captured buffers, count_samples' statistics, the tile map, the scene depth) with the cull
    forced on or off."""
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", cull)
    monkeypatch.setattr(occlusion_tiles, "HAIR_CULL", False)   # the head cull alone
    if form is not None:
        monkeypatch.setattr(raster_segment, "FORCED", form)
    s = RenderSettings(**{"size": (96, 72), "msaa": 1, "shadows": "none", "rasterizer": "compute",
                          "draw_head": head is not None, "strands_per_guide": 2, "width": 0.002, **kw})

    def tiles_and_depth(r):
        tiles = r.get_pass("hair_compute").tiles.read() if cull is not False else None
        _, depth = r.hdr_textures()
        return tiles, np.frombuffer(depth.read(), np.float32).reshape(depth.size[1], depth.size[0]).copy()

    bufs, stats, (tiles, z) = render_capture(gl, s, groom, head, camera, tiles_and_depth)
    return bufs, stats, tiles, z


def max_pool(z: np.ndarray, t: int) -> np.ndarray:
    """The max of each t x t tile of z (rows, columns), tiles past the edge over what is there."""
    h, w = z.shape
    th, tw = -(-h // t), -(-w // t)
    p = np.full((th * t, tw * t), -np.inf, np.float32)
    p[:h, :w] = z
    return p.reshape(th, t, tw, t).max(axis=(1, 3))


def sample_tiles(z: np.ndarray, grid: int) -> np.ndarray:
    """The tile map's twin: each pixel's depth at its grid x grid samples, pooled over tiles of
    TILE pixels a side rounded up to a power of two samples."""
    side = 1 << int(np.ceil(np.log2(depth_tiles.TILE * grid)))
    return max_pool(np.kron(z, np.ones((grid, grid), np.float32)), side)


def needles_groom(n: int = 60, seed: int = 4) -> Groom:
    """Straight strands of 3 points running from in front of a ball at the origin to behind it
    (mostly along the view axis, slanted): long segments with one end in front of the head's
    surface and one behind it."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, 3)[:, None]
    strands = []
    for _ in range(n):
        x, y = rng.uniform(-0.045, 0.045, 2)
        dx, dy = rng.uniform(-0.03, 0.03, 2)
        strands.append(np.c_[x + dx * t, y + dy * t, 0.09 - 0.18 * t])
    return Groom.from_strands(strands)


SCENES = {
    # every direction, strands through the eye's plane (ends projected far off the frame), a ball
    # behind the star's centre
    "star_eye": lambda: dict(groom=star_groom(), head=sphere(0.12, (0.05, 0.0, -0.15)),
                             camera=Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0)), width=0.003, segments=24,
                             strands_per_guide=1),
    # strands through a ball: segments from in front of the head to behind it
    "head_pierced": lambda: dict(groom=needles_groom(), head=sphere(0.04, (0.0, 0.0, 0.0)), camera=CAM,
                                 segments=2, strands_per_guide=1),
    # a ball between the eye and the curtain of hair: most of the hair behind it
    "head_in_front": lambda: dict(groom=curtain_groom(), head=sphere(0.035, (0.01, 0.0, 0.12)), camera=CAM),
    # the ball behind the curtain: the hair in front (nothing of it behind the head)
    "head_behind": lambda: dict(groom=curtain_groom(), head=sphere(0.05, (0.0, 0.0, -0.12)), camera=CAM),
    # the ball through the curtain, off centre: partly in front, partly behind, a silhouette across
    "head_partly": lambda: dict(groom=curtain_groom(), head=sphere(0.04, (0.03, -0.02, 0.0)), camera=CAM),
    # the default head and hair (hair over the scalp, behind the head, at its silhouette)
    "default_head": lambda: dict(zip(("groom", "head"), default_scene(num_guides=80, points=8, subdivisions=3))),
}
CASES = [("star_eye", 1, False), ("star_eye", 4, False), ("head_pierced", 1, False), ("head_pierced", 4, True), ("head_in_front", 1, False), ("head_in_front", 4, True), ("head_in_front", 16, False),
         ("head_behind", 4, False), ("head_partly", 1, False), ("head_partly", 4, True), ("head_partly", 16, True),
         ("default_head", 4, False), ("default_head", 16, True)]


@pytest.mark.parametrize("scene,msaa,head_msaa", CASES)
def test_head_cull_is_bit_identical_and_the_tile_map_is_the_max(gl, monkeypatch, scene, msaa, head_msaa):
    kw = SCENES[scene]()
    off, s_off, _, z = _render(gl, monkeypatch, False, msaa=msaa, head_msaa=head_msaa, **kw)
    on, s_on, tiles, z_on = _render(gl, monkeypatch, True, msaa=msaa, head_msaa=head_msaa, **kw)
    np.testing.assert_array_equal(z_on, z)
    assert (z < 1.0).sum() > 200 and (z == 1.0).sum() > 200   # head and background
    assert (off["ids"] >= 0).sum() > 200
    np.testing.assert_array_equal(on["ids"], off["ids"])
    assert_cover_equal(on["cover"], off["cover"])
    # the cull keeps what the visits mean: the samples the segments cover, the same writes
    culled = s_on.pop("sample_culled")
    assert s_off.pop("sample_culled") == 0
    assert s_on == s_off
    assert 0 <= culled <= s_on["sample_visits"] - s_on["sample_writes"]
    # the read-back converts the 24-bit depth to float apart from the shader's fetch: within a step
    np.testing.assert_allclose(tiles, sample_tiles(z, sample_grid(msaa)), rtol=0, atol=2.0 ** -24)
    assert (tiles < 1.0).any() and (tiles == 1.0).any()
    if scene in ("head_in_front", "default_head"):   # hair behind the head: columns skipped
        assert culled > 0.2 * (s_on["sample_visits"] - s_on["sample_writes"]), (culled, s_on)
    if scene == "head_behind":   # the hair is all in front of the head: nothing to skip
        assert culled == 0


@pytest.mark.parametrize("form", (0, 1))
@pytest.mark.parametrize("scene", ("head_in_front", "head_pierced"))
def test_head_cull_in_both_scan_conversion_forms(gl, monkeypatch, form, scene):
    kw = SCENES[scene]()
    off, s_off, _, _ = _render(gl, monkeypatch, False, form=form, msaa=4, **kw)
    on, s_on, _, _ = _render(gl, monkeypatch, True, form=form, msaa=4, **kw)
    np.testing.assert_array_equal(on["ids"], off["ids"])
    assert_cover_equal(on["cover"], off["cover"])
    assert s_on["sample_culled"] > 0 and s_on["sample_visits"] == s_off["sample_visits"]


def test_no_head_culls_nothing(gl, monkeypatch):
    kw = SCENES["head_in_front"]()
    kw["head"] = None
    bufs, stats, tiles, z = _render(gl, monkeypatch, True, msaa=4, **kw)
    assert (bufs["ids"] >= 0).sum() > 200
    assert stats["sample_culled"] == 0 and stats["sample_visits"] > 0
    assert (tiles == 1.0).all() and (z == 1.0).all()


def test_the_tile_map_of_a_known_depth(gl):
    # a depth texture with one known value per pixel, 21 x 11 (tiles cut at both edges), at 1,
    # 2 x 2 and 3 x 3 samples a pixel (tiles of 8, 16 and 32 samples; at 3 x 3 tile edges cut pixels)
    from mane.render.passes.depth_tiles import DepthTiles

    # (below 0.5: a pixel past the edge read as the clear's 1.0 would show), stored as 24 bits
    rng = np.random.default_rng(5)
    z = rng.uniform(0.0, 0.5, (11, 21)).astype(np.float32)
    tex = gl.depth_texture((21, 11), data=z.tobytes())
    t = DepthTiles(gl)
    try:
        for grid, side in ((1, 8), (2, 16), (3, 32)):
            t.update(tex, grid)
            assert t.tiles == (-(-21 * grid // side), -(-11 * grid // side))
            np.testing.assert_allclose(t.read(), max_pool(np.kron(z, np.ones((grid, grid), np.float32)), side),
                                       rtol=0, atol=2.0 ** -24)
    finally:
        t.release()
        tex.release()


@pytest.mark.parametrize("method", ("k_buffer", "dbk_buffer"))
def test_oit_fill_is_the_same_with_the_head_cull(gl, monkeypatch, method):
    # oit_raster.comp makes the same test at a fragment: every fragment of the frame (the OIT
    # capture: pixel, depth, segment, colour) and the kept depths, with the cull off and on,
    # hair partly behind a ball
    got = []
    for cull in (False, True):
        monkeypatch.setattr(depth_tiles, "HEAD_CULL", cull)
        r = Renderer(RenderSettings(size=(96, 72), msaa=1, rasterizer="compute", oit=method, oit_k=4,
                                    shadows="none"), ctx=gl, profile=False)
        try:
            r.set_strands(curtain_groom())
            r.set_head(sphere(0.06, (0.03, -0.02, 0.01)))
            m = r.get_pass("oit").current()
            m.capture, m.reset = True, False
            r.render(CAM, LIGHTS)
            f = m.captured
            order = np.lexsort((f["segment"], f["window_z"].view(np.uint32), f["pixel"]))
            tiles = m.tiles.read() if cull else None
            got.append(({k: np.asarray(v)[order] for k, v in f.items() if k != "size"},
                        m.read_slots()["zbits"], tiles))
        finally:
            r.release()
    (f0, z0, _), (f1, z1, tiles) = got
    assert len(f0["pixel"]) > 500
    assert (tiles < 1.0).sum() > 8   # the ball is in the map
    for k in f0:
        np.testing.assert_array_equal(f0[k], f1[k], err_msg=k)
    np.testing.assert_array_equal(z0, z1)


@pytest.mark.parametrize("part", ("segments", "columns"))
def test_each_part_of_the_cull_alone(gl, monkeypatch, part):
    # whole segments (their bounding box against their nearest depth) and single columns, each
    # alone (the A/B script measures them apart): the same buffers, samples skipped
    for scene in ("head_in_front", "head_pierced"):
        kw = SCENES[scene]()
        off, s_off, _, _ = _render(gl, monkeypatch, False, msaa=4, **kw)
        on, s_on, _, _ = _render(gl, monkeypatch, part, msaa=4, **kw)
        np.testing.assert_array_equal(on["ids"], off["ids"])
        assert_cover_equal(on["cover"], off["cover"])
        assert s_on["sample_visits"] == s_off["sample_visits"] and s_on["sample_writes"] == s_off["sample_writes"]
        if scene == "head_in_front":
            assert s_on["sample_culled"] > 0.2 * (s_on["sample_visits"] - s_on["sample_writes"])


def test_the_cull_by_renderer(gl, monkeypatch):
    # segments always; columns with the balanced scan conversion (GPUs), not in the per-thread
    # form (CPU rasterisers: a lane's skipped column saves nothing while its neighbours walk on)
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", None)
    for form in (0, 1):
        monkeypatch.setattr(raster_segment, "FORCED", form)
        assert depth_tiles.cull_defines(gl) == {"RASTER_HEAD_CULL": 1, "RASTER_CULL_SPANS": 1,
                                                "RASTER_CULL_COLUMNS": form}
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", False)
    assert depth_tiles.cull_defines(gl)["RASTER_HEAD_CULL"] == 0


def test_a_bad_cull_switch_is_refused(gl, monkeypatch):
    monkeypatch.setattr(depth_tiles, "HEAD_CULL", "tiles")
    with pytest.raises(ValueError, match="HEAD_CULL"):
        depth_tiles.cull_defines(gl)
