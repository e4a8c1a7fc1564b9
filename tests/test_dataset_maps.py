"""The data set's ground-truth maps (mane.render.aux_maps, aux_maps.comp) against their NumPy
twin (src/mane/twins/aux.py), and a data set sample's maps against the same
strands projected with the camera it writes (camera.json's OpenCV K and extrinsics)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mane.render import Renderer, RenderSettings
from mane.render.aux_maps import AuxMaps
from mane.grooming.scene import default_scene

from mane.twins.aux import aux_maps

pytestmark = pytest.mark.gpu


def _circular(a, b):
    d = np.abs(np.asarray(a, float) - np.asarray(b, float)) % math.pi
    return np.minimum(d, math.pi - d)


@pytest.mark.parametrize("msaa", [1, 4])
def test_maps_match_the_numpy_twin(gl, msaa):
    groom, head = default_scene(num_guides=40, points=8, subdivisions=3)
    s = RenderSettings(size=(64, 48), rasterizer="compute", msaa=msaa, shadows="none", strands_per_guide=3,
                       segments=14)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        aux = AuxMaps(r)
        r.render(r.default_camera(30.0, 10.0))
        got = aux.read()
        e = r.get_pass("expand").read()
        _, depth_tex = r.hdr_textures()
        scene = np.frombuffer(depth_tex.read(), np.float32).reshape(48, 64)
        v = r.last_frame.view
        g = r.raster_grid
    finally:
        r.release()
    ref = aux_maps(e, dict(view_proj=v.view_proj, eye=v.eye, forward=v.forward, ortho=v.ortho,
                           pixel_size=v.pixel_size, min_pixel_width=v.min_pixel_width, size=(64 * g, 48 * g),
                           grid=g), 3, scene_depth=scene)
    hit = ref["segment"] >= 0
    assert hit.sum() > 80
    # float32 on the GPU against float64 here: a sample on an edge or a depth tie may differ
    same = got["segment"] == ref["segment"]
    assert (~same).mean() < 0.01, (~same).sum()
    both = same & hit
    for k in ("strand", "guide"):
        np.testing.assert_array_equal(got[k][same], ref[k][same])
    assert np.all(got["strand"][~hit & same] == 0xFFFFFFFF)
    np.testing.assert_allclose(got["depth"][both], ref["depth"][both], rtol=1e-4)
    assert _circular(got["angle"][both], ref["angle"][both]).max() < 2e-3
    assert np.all((got["angle"] >= 0) & (got["angle"] < math.pi))
    np.testing.assert_allclose(got["confidence"][both], ref["confidence"][both], atol=2e-3)
    np.testing.assert_allclose(got["alpha"], ref["alpha"], atol=2e-3)
    if msaa == 1:   # one sample: every direction agrees with itself
        assert np.all(got["confidence"][both] > 0.999)
    else:
        assert got["confidence"][both].min() < 0.99   # crossings exist at 2x2 samples


def test_sample_maps_agree_with_the_strands_through_the_written_camera(gl, tmp_path):
    # a data set sample: project the nearest segment's ends with camera.json's OpenCV K and
    # world_to_camera: the pixel centre lies on it, its depth is the map's, its image direction
    # the orientation map's; strand and guide ids name a strand rooted at that guide
    from mane import save
    from mane.dataset.sampling import sample_params
    from mane.dataset.spec import parse_spec
    from mane.dataset.worker import SampleRenderer

    groom, _ = default_scene(num_guides=30, points=8, subdivisions=3)
    save(groom, tmp_path / "g.npz")
    spec = parse_spec({"samples": 2, "size": [64, 64], "heads": ["none"], "grooms": [{"file": "g.npz"}],
                       "views": {"distance": [0.7, 0.8], "azimuth": [-40, 40]},
                       "render": {"strands_per_guide": 2, "msaa": 4, "shadows": "none", "segments": 14}}, tmp_path)
    sr = SampleRenderer(spec, ctx=gl)
    try:
        raw = sr.render(sample_params(spec, 1))
        raw["segment"] = sr.aux.read()["segment"]   # the same frame's (a sample's files leave it out)
        e = sr.renderer.get_pass("expand").read()
        guides = sr.renderer.strands.read_positions()
    finally:
        sr.release()
    cam = raw["camera"]
    K, E = np.array(cam["K"]), np.array(cam["world_to_camera"])
    pts = e[..., :3].reshape(-1, 3).astype(np.float64)
    X = np.c_[pts, np.ones(len(pts))] @ E.T
    uv = (X[:, :3] @ K.T)
    uv = uv[:, :2] / uv[:, 2:3]
    Z = X[:, 2]
    hit = raw["segment"] >= 0
    assert hit.sum() > 100
    vs, us = np.nonzero(hit)
    i = raw["segment"][hit]
    a, b = uv[i], uv[i + 1]
    c = np.c_[us, vs] + 0.5
    d = b - a
    ts = np.clip(((c - a) * d).sum(1) / np.maximum((d * d).sum(1), 1e-12), 0, 1)
    dist = np.linalg.norm(a + ts[:, None] * d - c, axis=1)
    assert np.percentile(dist, 99) < 1.5 and dist.max() < 3.0    # strands are ~1 pixel wide here
    t = ts / Z[i + 1] / ((1 - ts) / Z[i] + ts / Z[i + 1])      # perspective-correct: 1/Z is affine
    depth = Z[i] + t * (Z[i + 1] - Z[i])
    np.testing.assert_allclose(raw["depth"][hit], depth, rtol=1e-4)
    angle = np.arctan2(-d[:, 1], d[:, 0]) % math.pi               # image rows grow downward
    assert _circular(raw["angle"][hit], angle).max() < 2e-3
    P = e.shape[1]
    np.testing.assert_array_equal(raw["strand"][hit], i // P)
    np.testing.assert_array_equal(raw["guide"][hit], i // P // 2)
    roots = e[:, 0, :3]
    gap = np.linalg.norm(roots[i // P] - guides[i // P // 2, 0], axis=1)
    assert gap.max() < 0.01   # a rendered strand's root sits within its clump around its guide
    # the strands written in camera space are the groom's points through the same extrinsics
    np.testing.assert_allclose(raw["strands"]["points"],
                               (np.c_[groom.points, np.ones(groom.num_points)] @ E.T)[:, :3], atol=1e-5)
    assert np.all(raw["depth"][~hit] == 0) and np.all(raw["guide"][~hit] == 0xFFFFFFFF)
    assert np.all(raw["alpha"][hit] > 0)
