"""One fibre drawn by the real-time renderer has Chiang's far-field radiance, lit from any side.

The golden value is the NumPy twin of Chiang 2016 (mane.twins.chiang, itself checked against
Mitsuba's hair BSDF in tests/test_chiang.py), not the renderer's tables: the picture's radiance
over the pixels the fibre covers (RGB premultiplied, divided by the coverage) is f |cos theta_i| E
at the fibre's angles, and the coverage integrated across the fibre is its width. The path
tracer's fibre meets the same golden value (tests/test_reference.py). This checks the whole frame (the renderer's tangent, view and light vectors, the tilt's
sign along root -> tip, the tables' look-up, the fibre's coverage) on both rasterisers, with
the light behind the fibre (TT), beside it and in front, each off the fibre's normal plane.
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


@pytest.mark.parametrize("rasterizer", ["hardware", "compute"])
@pytest.mark.parametrize("toward_light", [(0.3, 0.3, -1.0), (-0.2, 1.0, 0.0), (0.4, 1.0, 1.0)],
                         ids=["behind", "beside", "above_front"])
def test_one_fibre_has_chiangs_far_field_radiance(gl, rasterizer, toward_light):
    # a straight guide across a 2-degree view from +z (theta_o = 0 within 1 degree), root first,
    # 3 degrees off the rows so that its edges cross the pixels' samples at every offset
    T = np.array([math.cos(math.radians(3.0)), math.sin(math.radians(3.0)), 0.0])
    groom = Groom((np.linspace(-0.1, 0.1, 16)[:, None] * T).astype(np.float32), np.array([16], np.int32))
    settings = RenderSettings(size=(SIZE, SIZE), strands_per_guide=1, hair_color=None, width=WIDTH, width_tip=1.0,
                              shading="chiang", shading_options={"melanin": MELANIN, "multiple_scattering": "none",
                                                                 "roughness": ROUGHNESS, "shift": SHIFT},
                              shadows="none", ambient=0.0, background=(0.0, 0.0, 0.0), tone_mapping="none",
                              exposure=1.0, strand_spread=0.0, draw_head=False, rasterizer=rasterizer, accumulate=8)
    cam = Camera(eye=(0, 0, D), target=(0, 0, 0), fov_y=FOV)
    img, drawn = still_picture(gl, settings, groom, None, cam, [Light("directional", toward_light, (1, 1, 1), E)])
    assert drawn == rasterizer
    middle = img[:, SIZE // 4:3 * SIZE // 4]                      # the fibre crosses every column
    view = 2 * D * math.tan(math.radians(FOV) / 2)
    coverage = middle[..., 3].sum(axis=0).mean() * (view / SIZE) / (WIDTH / T[0])   # of the fibre's strip
    assert coverage == pytest.approx(1.0, abs=0.02)
    radiance = middle[..., :3].sum(axis=(0, 1)) / middle[..., 3].sum()   # RGB is premultiplied by coverage
    L = np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    V = np.array([0.0, 0.0, 1.0])
    lp, vp = L - (L @ T) * T, V - (V @ T) * T                   # their parts across the fibre
    phi = math.acos(lp @ vp / (np.linalg.norm(lp) * np.linalg.norm(vp)))
    expected = E * C.fibre([math.asin(L @ T)], [math.asin(V @ T)], [phi], melanin_to_sigma_a(*MELANIN),
                           roughness=ROUGHNESS, shift=SHIFT, beta_n=0.3)[0]
    np.testing.assert_allclose(radiance, expected, rtol=0.01)
