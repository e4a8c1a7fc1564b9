"""How the shadow map is looked up: the gathered PCF against a NumPy twin of its filter, and the
hair's per-vertex look-ups (``hair_shadow_lookup="vertex"``) against the per-fragment ones.

The scene is the shadow validation's curtain of strands lit from the side
(mane.bench.quality; tests/test_render_shadows.py tests the same look-up against an exact ray
cast)."""
from __future__ import annotations

import numpy as np
import pytest

from mane.bench.quality import curtain_groom, shadow_light, shadow_renderer, shadow_settings
from mane.render.shadow_probe import probe_visibility

pytestmark = pytest.mark.gpu

LIGHT = shadow_light()


def numpy_box_of(value, uv, n_box, n):
    """The mean of ``value(tx, ty)`` (each point's value at texels tx, ty) over lighting.glsl's
    PCF_BOX of n_box x n_box texels of an n x n map centred on uv, in float64."""
    s = uv * n - 0.5 - 0.5 * (n_box - 1)
    b = np.floor(s)
    f = s - b
    out = 0.0
    for j in range(n_box + 1):
        wy = np.where(j == 0, 1 - f[:, 1], np.where(j == n_box, f[:, 1], 1.0))
        for i in range(n_box + 1):
            wx = np.where(i == 0, 1 - f[:, 0], np.where(i == n_box, f[:, 0], 1.0))
            tx = np.clip(b[:, 0].astype(int) + i, 0, n - 1)
            ty = np.clip(b[:, 1].astype(int) + j, 0, n - 1)
            out = out + wx * wy * value(tx, ty)
    return out / n_box ** 2


def numpy_pcf(depth_map, uv, ref, pcf):
    """PCF of ``ref <= texel`` over a pcf x pcf texel box centred on uv (continuous texel units:
    texel i's centre at i), each texel weighted by its overlap with the box, texels clamped to
    the map: (M,) in [0, 1]. The filter lighting.glsl documents, in float64."""
    return numpy_box_of(lambda tx, ty: ref <= depth_map[ty, tx], uv, pcf, depth_map.shape[0])


@pytest.mark.parametrize("pcf", [1, 2, 3])
def test_gathered_pcf_matches_a_numpy_twin(gl, pcf):
    # lighting.glsl's shadow-map look-up (4 texels a textureGather, the kernel a compile-time
    # constant) against the box filter computed here from the map read back, at points inside
    # the curtain and around it: the same texels and weights, so equal to float precision
    # (a texel whose depth ties the point's to ~1e-7 m could flip; none should)
    groom = curtain_groom()
    r = shadow_renderer(gl, groom, shadow_settings(shadow_map_size=64), shadows="shadow_map", pcf=pcf)
    try:
        r.render(None, [LIGHT])
        depth = r.get_pass("shadow_map").read().astype(np.float64)
        lv = r.last_frame.light_view
        lo, hi = r.strands.bbox()
        pts = np.random.default_rng(pcf).uniform(lo - 0.01, hi + 0.01, (3000, 3))
        got = probe_visibility(r, pts).astype(np.float64)
        bias = float(r.settings.shadow_bias) * float(lv.pixel_size)   # ortho: texels of pixel_size
    finally:
        r.release()
    assert lv.ortho
    c = np.c_[pts, np.ones(len(pts))] @ np.asarray(lv.view_proj, np.float64).T
    uv = c[:, :2] / c[:, 3:4] * 0.5 + 0.5
    z = (pts - np.asarray(lv.eye, np.float64)) @ np.asarray(lv.forward, np.float64)
    want = numpy_pcf(depth, uv, z - bias, pcf)
    partial = (want > 0.05) & (want < 0.95)
    assert partial.sum() > 100 and (want < 0.05).sum() > 100   # penumbrae and umbrae both probed
    err = np.abs(got - want)
    assert np.mean(err > 1e-4) < 0.002, (err.max(), np.mean(err > 1e-4))   # measured: max 3.5e-6
    assert np.mean(err) < 1e-5


@pytest.mark.parametrize("pipeline", ["compute", "tessellation"])   # hair_pull.vert, hair.geom
def test_hair_vertex_lookups_match_the_fragment_lookups(gl, pipeline):
    # The hair shaded with its shadows looked up at the strand points and interpolated along the
    # segments against the same frame looked up per fragment (the look-up the test above and
    # test_render_shadows check against a NumPy twin and an exact ray cast): the difference is
    # small against the shadow itself (no shadow at all differs by 1.0 of it; per vertex
    # measured 0.05 on llvmpipe, 12 points a strand, a 64-texel map).
    from mane.render.camera import Camera

    groom = curtain_groom()
    cam = Camera(eye=(0.0, 0.0, 0.35), target=(0.0, 0.0, 0.0), fov_y=40.0, near=0.05, far=2.0)
    img = {}
    for name, kw in (("none", dict(shadows="none")), ("fragment", dict(shadows="shadow_map")),
                     ("vertex", dict(shadows="shadow_map", hair_shadow_lookup="vertex"))):
        # the raster units' shading (the compute rasteriser, an H200's default, looks up per sample)
        r = shadow_renderer(gl, groom, {**shadow_settings(shadow_map_size=64), "size": (160, 160),
                                        "pipeline": pipeline, "rasterizer": "hardware"}, **kw)
        try:
            r.render(cam, [LIGHT])
            img[name] = r.read_image().astype(np.float64)
        finally:
            r.release()
    shadow = np.abs(img["fragment"] - img["none"]).mean()
    assert shadow > 1.0                                   # the shadows show
    ratio = np.abs(img["vertex"] - img["fragment"]).mean() / shadow
    assert 0.0 < ratio < 0.1, ratio                       # 0: the setting did nothing


@pytest.mark.parametrize("footprint", [2, 3])
def test_multiple_scatterings_light_and_the_hair_behind_match_a_numpy_twin(gl, footprint):
    """light0_visibility_ms's multiple-scattering transmittance (the deep opacity map's
    transmittance at the point's depth, averaged over ms_shadow_footprint texels) and its share
    that meets hair beyond the point, 1 - (the box's transmittance through the whole column) /
    (the box's at the point), against the same sums here from the map read back."""
    groom = curtain_groom()
    r = shadow_renderer(gl, groom, shadow_settings(shadow_map_size=64), shadows="deep_opacity",
                        ms_shadow_footprint=footprint)
    try:
        r.render(None, [LIGHT])
        dom = r.get_pass("deep_opacity").read().astype(np.float64)   # O1, O2, O3, z0
        frame = r.last_frame
        lv = frame.light_view
        lo, hi = r.strands.bbox()
        pts = np.random.default_rng(footprint).uniform(lo - 0.01, hi + 0.01, (3000, 3))
        ms = probe_visibility(r, pts, term="ms").astype(np.float64)
        behind = probe_visibility(r, pts, term="behind").astype(np.float64)
        d0, d1 = frame.hair_depth_range
        layers = np.array(r.settings.dom_layers, np.float64) * max(d1 - d0, 1e-4)
        density = float(r.settings.shadow_density)
    finally:
        r.release()
    c = np.c_[pts, np.ones(len(pts))] @ np.asarray(lv.view_proj, np.float64).T
    uv = c[:, :2] / c[:, 3:4] * 0.5 + 0.5
    z = (pts - np.asarray(lv.eye, np.float64)) @ np.asarray(lv.forward, np.float64)
    n = dom.shape[0]

    def opacity(tx, ty):   # lighting.glsl's dom_opacity: piecewise linear through the layers
        t = dom[ty, tx]
        dz = z - t[:, 3]
        o1, o2, o3 = t[:, 0], t[:, 1], t[:, 2]
        return np.select([dz <= 0, dz < layers[0], dz < layers[1], dz < layers[2]],
                         [0.0, o1 * dz / layers[0], o1 + (o2 - o1) * (dz - layers[0]) / (layers[1] - layers[0]),
                          o2 + (o3 - o2) * (dz - layers[1]) / (layers[2] - layers[1])], o3)

    want_ms = numpy_box_of(lambda tx, ty: np.exp(-density * opacity(tx, ty)), uv, footprint, n)
    want_total = numpy_box_of(lambda tx, ty: np.exp(-density * dom[ty, tx, 2]), uv, footprint, n)
    want_behind = 1.0 - np.minimum(want_total / np.maximum(want_ms, 1e-30), 1.0)
    inside = (want_behind > 0.05) & (want_behind < 0.95)
    assert inside.sum() > 200 and (want_behind < 0.01).sum() > 100   # points with hair behind and without
    assert np.mean(np.abs(ms - want_ms)) < 1e-5 and np.mean(np.abs(ms - want_ms) > 1e-4) < 0.002
    assert np.mean(np.abs(behind - want_behind)) < 1e-5 and np.mean(np.abs(behind - want_behind) > 1e-4) < 0.002
    assert np.all((behind >= 0) & (behind <= 1))
