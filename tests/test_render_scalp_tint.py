"""The scalp's albedo: ``scalp_tint`` of the way from skin_color to the hair's colour, where the
head's "scalp" vertex weight is 1 (0: the skin, what the path-traced reference draws)."""
from __future__ import annotations

import numpy as np
import pytest

from mane.render.passes.head_pass import scalp_albedo

SKIN = (0.5, 0.32, 0.24)
HAIR = (0.1, 0.05, 0.02)


def test_scalp_albedo_goes_from_the_skin_to_the_hair():
    assert scalp_albedo(SKIN, HAIR, 0.0) == pytest.approx(SKIN)
    assert scalp_albedo(SKIN, HAIR, 1.0) == pytest.approx(HAIR)
    # the renderer's look until 2026-12-02: 0.8 hair + 0.2 skin
    assert scalp_albedo(SKIN, HAIR, 0.8) == pytest.approx((0.18, 0.104, 0.064))


def test_scalp_tint_is_a_declared_setting_with_the_old_look_by_default():
    from mane.errors import UsageError
    from mane.render import RenderSettings

    assert RenderSettings().scalp_tint == 0.8
    with pytest.raises(UsageError):
        RenderSettings(scalp_tint=1.5)


@pytest.mark.gpu
@pytest.mark.parametrize("tint", [0.0, 0.8])
def test_an_all_scalp_head_under_ambient_light_is_its_albedo(gl, tint):
    """A sphere whose every vertex is scalp, lit by ambient radiance A alone (no lights, no
    shadows, linear HDR, tone mapping off): every covered pixel is A x the scalp's albedo."""
    from mane.grooming.head import icosphere
    from mane.mesh import Mesh
    from mane.render import Renderer, RenderSettings
    from mane.render.camera import Camera

    v, f = icosphere(2)
    sphere = Mesh(v * 0.1, f, vertex_attributes={"scalp": np.ones(len(v), np.float32)})
    ambient = 2.0
    s = RenderSettings(size=(32, 32), hair_color=HAIR, skin_color=SKIN, scalp_tint=tint, ambient=ambient,
                       shadows="none", tone_mapping="none", exposure=1.0, background=(0.0, 0.0, 0.0),
                       supersample=1, draw_head=True)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_head(sphere)
        r.render(Camera(eye=(0.0, 0.0, 0.5), target=(0.0, 0.0, 0.0), fov_y=30.0, near=0.05, far=3.0), [])
        tex = r.resolved_hdr()
        raw = np.frombuffer(tex.read(), np.float16 if tex.dtype == "f2" else np.float32)
        img = raw.reshape(32, 32, tex.components).astype(np.float64)
    finally:
        r.release()
    expected = ambient * ((1.0 - tint) * np.array(SKIN) + tint * np.array(HAIR))
    centre = img[12:20, 12:20, :3].reshape(-1, 3)
    assert np.allclose(centre, expected, rtol=2e-3, atol=1e-4)
