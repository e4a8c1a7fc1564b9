"""The head shaded by compute (head_pass.SHADE_BY_COMPUTE; head_shade.comp over the raster units'
depth and triangle ids) against head.frag shading every fragment: the same picture within one
8-bit step (the point is found by the pixel ray's hit on the triangle instead of the raster
units' interpolation; a pixel on a hard shadow edge may fall on the other side). GPUs use it
by default; on a CPU rasteriser (these tests) it is forced."""
from __future__ import annotations

import numpy as np
import pytest

import mane.render.passes.head_pass as head_pass
from mane.grooming.scene import default_groom, default_head
from mane.render import Renderer, RenderSettings

pytestmark = pytest.mark.gpu


def _image(gl, monkeypatch, by_compute, hair, transform=None, **kw):
    monkeypatch.setattr(head_pass, "SHADE_BY_COMPUTE", by_compute)
    head = default_head(3)
    r = Renderer(RenderSettings(size=(160, 120), **kw), ctx=gl, profile=False)
    try:
        if hair:
            r.set_strands(default_groom(head, 120, 9))
        r.set_head(head)
        if transform is not None:
            r.set_head_transform(transform)
        cam = r.default_camera(azimuth=70, distance_scale=0.6, points=None)
        used = r.get_pass("head")
        img = r.render_image(cam)
        slots = used._programs._slots
        return img.astype(int), "head_shade" in slots, "head" in slots
    finally:
        r.release()


def _turn(deg):
    a = np.radians(deg)
    m = np.eye(4)
    m[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    m[:3, 3] = (0.01, 0.0, 0.0)
    return m


@pytest.mark.parametrize("hair, transform, kw", [
    (False, None, dict(rasterizer="compute", shadow_lights=1)),
    (True, None, dict(rasterizer="compute", shadow_lights=1)),
    (True, _turn(30), dict(rasterizer="compute", supersample=2, shadow_lights=1)),
    (False, None, dict(rasterizer="hardware", msaa=1, shadow_lights=1)),
    (False, None, dict(rasterizer="compute", shadow_lights=4)),   # the default rig's lights all casting
])
def test_compute_head_matches_the_fragment_shader(gl, monkeypatch, hair, transform, kw):
    frag, used_compute, _ = _image(gl, monkeypatch, False, hair, transform, **kw)
    assert not used_compute
    comp, used_compute, _ = _image(gl, monkeypatch, True, hair, transform, **kw)
    assert used_compute
    d = np.abs(frag - comp).max(axis=2)
    skin = frag.sum(axis=2) > 30
    assert skin.mean() > 0.1                      # the head fills a good part of the frame
    assert (d > 1).mean() < 2e-3, (d > 1).sum()   # hard shadow edges only
    assert d.mean() < 0.05


def test_multisampled_heads_keep_the_fragment_shader(gl, monkeypatch):
    _, used_compute, used_frag = _image(gl, monkeypatch, True, False, rasterizer="hardware", msaa=4)
    assert not used_compute and used_frag


def test_the_default_shades_by_compute_on_gpus_only(gl, monkeypatch):
    """CPU rasterisers keep the fragment shader (SHADE_BY_COMPUTE None: by the renderer)."""
    from mane.gpu.capabilities import get_capabilities

    _, used_compute, used_frag = _image(gl, monkeypatch, None, False, rasterizer="compute")
    software = get_capabilities(gl).is_software
    assert used_compute == (not software) and used_frag == software


@pytest.mark.parametrize("azimuth, distance, supersample", [(70, 0.6, 1), (20, 0.35, 1), (200, 0.5, 2)])
def test_every_head_pixel_is_shaded_and_no_other(gl, monkeypatch, azimuth, distance, supersample):
    """head_shade.comp runs over the head's screen box only (Renderer.head_screen_box): every
    pixel the raster units gave the head's depth is written (alpha 1), none else (alpha 0)."""
    monkeypatch.setattr(head_pass, "SHADE_BY_COMPUTE", True)
    r = Renderer(RenderSettings(size=(160, 120), rasterizer="compute", supersample=supersample), ctx=gl,
                 profile=False)
    try:
        r.set_head(default_head(3))
        r.render(r.default_camera(azimuth=azimuth, distance_scale=distance, points=None))
        color, depth = r.hdr_textures()
        w, h = depth.size
        alpha = np.frombuffer(color.read(), np.float16).reshape(h, w, 4)[..., 3]
        head = np.frombuffer(depth.read(), np.float32).reshape(h, w) < 1.0
        assert 0.05 < head.mean() < 1.0   # a head on screen, and pixels without it
        assert np.array_equal(alpha == 1.0, head)
        assert np.all(alpha[~head] == 0.0)
    finally:
        r.release()
