"""One fibre drawn by the real-time renderer has Chiang's radiance, lit from any side.

The golden value is the NumPy twin of Chiang 2016 (mane.twins.chiang, itself checked against
Mitsuba's hair BSDF in tests/test_chiang.py), not the renderer's tables: the picture's radiance
over the pixels the fibre covers (RGB premultiplied, divided by the coverage) is f |cos theta_i| E
at the fibre's angles, and the coverage integrated across the fibre is its width; with the near
field on, each pixel of a wide fibre is the twin's near field averaged over the part of the width
the pixel covers. The path tracer's fibre meets the same golden values (tests/test_reference.py).
This checks the whole frame (the renderer's tangent, view and light vectors, the tilt's sign
along root -> tip, the tables' look-up, the offset across the fibre, the coverage) on both
rasterisers, with the light behind the fibre (TT), beside it and in front, each off the fibre's
normal plane.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from mane import Groom
from mane.bench.fidelity import still_picture
from mane.render import RenderSettings
from mane.render.camera import Camera
from mane.render.lights import Light
from mane.render.shading.melanin import melanin_to_sigma_a
from mane.twins import chiang as C

D, FOV, SIZE, WIDTH, E = 1.0, 2.0, 64, 2e-3, 1.5
MELANIN = (0.3, 0.1)
ROUGHNESS, SHIFT = math.radians(7.5), math.radians(-5.0)


T = np.array([math.cos(math.radians(3.0)), math.sin(math.radians(3.0)), 0.0])   # 3 degrees off the rows
VIEW = 2 * D * math.tan(math.radians(FOV) / 2)                                  # metres across the view


def _draw(gl, rasterizer, width, toward_light, near_field, accumulate, pipeline="compute", still_near_field=False):
    """One straight guide along T through the origin (root first), ``width`` m wide, seen from
    +z across a 2-degree view (theta_o = 0 within 1 degree), lit by one directional light: the
    still picture (linear, premultiplied; its frames' near field as ``still_near_field``)."""
    groom = Groom((np.linspace(-0.1, 0.1, 16)[:, None] * T).astype(np.float32), np.array([16], np.int32))
    settings = RenderSettings(size=(SIZE, SIZE), strands_per_guide=1, hair_color=None, width=width, width_tip=1.0,
                              shading="chiang", shading_options={"melanin": MELANIN, "multiple_scattering": "none",
                                                                 "roughness": ROUGHNESS, "shift": SHIFT,
                                                                 "near_field": near_field},
                              shadows="none", ambient=0.0, background=(0.0, 0.0, 0.0), tone_mapping="none",
                              exposure=1.0, strand_spread=0.0, draw_head=False, rasterizer=rasterizer,
                              accumulate=accumulate, pipeline=pipeline, still_near_field=still_near_field)
    cam = Camera(eye=(0, 0, D), target=(0, 0, 0), fov_y=FOV)
    img, drawn = still_picture(gl, settings, groom, None, cam, [Light("directional", toward_light, (1, 1, 1), E)])
    assert drawn == rasterizer
    return img


def _far_field(toward_light):
    """E f |cos theta_i| of the twin's far field at the fibre's angles (the eye on +z)."""
    L = np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    V = np.array([0.0, 0.0, 1.0])
    lp, vp = L - (L @ T) * T, V - (V @ T) * T                   # their parts across the fibre
    phi = math.acos(lp @ vp / (np.linalg.norm(lp) * np.linalg.norm(vp)))
    return E * C.fibre([math.asin(L @ T)], [math.asin(V @ T)], [phi], melanin_to_sigma_a(*MELANIN),
                       roughness=ROUGHNESS, shift=SHIFT, beta_n=0.3)[0]


@pytest.mark.parametrize("rasterizer", ["hardware", "compute"])
@pytest.mark.parametrize("toward_light", [(0.3, 0.3, -1.0), (-0.2, 1.0, 0.0), (0.4, 1.0, 1.0)],
                         ids=["behind", "beside", "above_front"])
def test_one_fibre_has_chiangs_far_field_radiance(gl, rasterizer, toward_light):
    # the far field (near_field off), 3.7 px wide, its edges across the pixels' samples at every offset
    img = _draw(gl, rasterizer, WIDTH, toward_light, near_field=False, accumulate=8)
    middle = img[:, SIZE // 4:3 * SIZE // 4]                      # the fibre crosses every column
    coverage = middle[..., 3].sum(axis=0).mean() * (VIEW / SIZE) / (WIDTH / T[0])   # of the fibre's strip
    assert coverage == pytest.approx(1.0, abs=0.02)
    radiance = middle[..., :3].sum(axis=(0, 1)) / middle[..., 3].sum()   # RGB is premultiplied by coverage
    np.testing.assert_allclose(radiance, _far_field(toward_light), rtol=0.01)


def _pixel_means(img, L, width):
    """(the picture's radiance per coverage, the twin's) at the pixels well inside a fibre
    through the origin along T seen from +z. The twin: Chiang's near field averaged over the
    part of the fibre's width one pixel covers (ShadingSettings.near_field: h +- 1 / width in
    pixels, h along cross(T, V)) at the pixel's centre."""
    px = VIEW / SIZE
    rows, cols = np.indices((SIZE, SIZE))
    X, Y = (cols + 0.5 - SIZE / 2) * px, (SIZE / 2 - rows - 0.5) * px     # the plane z = 0, top row first
    side = np.cross(T, [0.0, 0.0, 1.0])[:2]
    side /= np.linalg.norm(side)
    half = width / 2
    inside = (np.abs(X * side[0] + Y * side[1]) < 0.85 * half) & (cols >= SIZE // 4) & (cols < 3 * SIZE // 4)
    dh = 2.0 * px / width
    sigma = melanin_to_sigma_a(*MELANIN)
    Xs, Ys = X[inside], Y[inside]
    P = np.stack([Xs, Ys, np.zeros_like(Xs)], -1)
    V = np.array([0.0, 0.0, D]) - P
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    h = (Xs * side[0] + Ys * side[1]) / half
    angles = C.signed_angles(np.broadcast_to(T, V.shape), V, np.broadcast_to(L, V.shape))
    expected = E * C.near_mean(*angles, h - dh / 2, h + dh / 2, sigma, roughness=ROUGHNESS, shift=SHIFT, beta_n=0.3,
                               steps=16)
    got = img[..., :3][inside] / np.maximum(img[..., 3][inside], 1e-6)[:, None]
    return got, expected


@pytest.mark.parametrize("rasterizer, pipeline", [("hardware", "compute"), ("hardware", "tessellation"),
                                                   ("compute", "compute")],
                         ids=["hardware", "hardware_tessellation", "compute"])
@pytest.mark.parametrize("toward_light", [(0.3, 0.3, -1.0), (-0.2, 1.0, 0.0), (0.4, 1.0, 1.0), (0.0, -0.5, 1.0)],
                         ids=["behind", "beside", "above_front", "below_front"])
@pytest.mark.parametrize("pixels", [3, 16])
def test_a_wide_fibre_shows_the_near_field_each_pixel_covers(gl, rasterizer, pipeline, toward_light, pixels):
    # A fibre 3 or 16 px wide (the raster units fed by vertex pulling, hair_pull.vert, or by the
    # tessellation and geometry stages, hair.geom): each pixel shows the mean of Chiang's fibre
    # over the part of its width the pixel covers (ShadingSettings.near_field), as the path tracer's pixel does; a
    # frame of its own, whose shading window is the pixel on both rasterisers (a still picture's
    # frames move it by their sub-pixel offsets). The far field (the mean over the whole width)
    # is 0.4-1.6 off per pixel here, and the near field with h mirrored 1.1-1.9.
    width = pixels * VIEW / SIZE
    img = _draw(gl, rasterizer, width, toward_light, near_field=True, accumulate=1, pipeline=pipeline)
    L = np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    got, expected = _pixel_means(img, L, width)
    per_pixel = np.abs(got - expected).sum() / expected.sum()
    assert per_pixel < 0.04, per_pixel
    # the pixels' windows tile the fibre: its light over all the pixels it covers is the far field's
    # (within the edge pixels' coverage, 4 samples in one frame)
    middle = img[:, SIZE // 4:3 * SIZE // 4]
    np.testing.assert_allclose(middle[..., :3].sum(axis=(0, 1)) / middle[..., 3].sum(), _far_field(toward_light),
                               rtol=0.05 if pixels < 8 else 0.02)


@pytest.mark.parametrize("rasterizer, bound", [("compute", 0.05), ("hardware", 0.25)])
def test_a_still_picture_shows_a_wide_fibres_near_field_by_default(gl, rasterizer, bound):
    # RenderSettings.still_near_field (on by default): a still picture's frames shade with the
    # near field though the frames' own setting is off, so a 16-px fibre's pixels follow the twin's
    # near field; with it off they show the far field, 1.05 off per pixel. The raster units' still
    # picture resolves each sample with its fragment's one colour, which blurs the shading across
    # about two pixels (docs/quality.md): 0.18 there, 0.03 on the compute rasteriser.
    assert RenderSettings().still_near_field
    width = 16 * VIEW / SIZE
    toward_light = (0.4, 1.0, 1.0)
    L = np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    errors = []
    for still_near_field in (True, False):
        img = _draw(gl, rasterizer, width, toward_light, near_field=False, accumulate=8,
                    still_near_field=still_near_field)
        got, expected = _pixel_means(img, L, width)
        errors.append(np.abs(got - expected).sum() / expected.sum())
    assert errors[0] < bound, errors
    assert errors[1] > 0.5, errors
