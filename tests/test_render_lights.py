"""Several lights, two (or more) casting shadows: every shadow-casting light gets its own maps
(shadow map; with deep opacity maps, its own opacity layers) and darkens where it should."""
from __future__ import annotations

import numpy as np
import pytest

from mane.groom import Groom
from mane.mesh import Mesh
from mane.render import Camera, Light, Renderer, RenderSettings

pytestmark = pytest.mark.gpu

CAM = Camera(eye=(0.0, 0.25, 0.55), target=(0.0, -0.02, 0.0), fov_y=30.0, near=0.05, far=3.0)
RECEIVER = (np.array([0.0, -0.2, 0.0]), 0.2)
OCCLUDER = (np.array([0.0, 0.06, 0.0]), 0.025)
LIGHTS = [Light("directional", (1.0, 1.2, 0.0), intensity=2.0),
          Light("directional", (-1.0, 1.2, 0.0), intensity=2.0),
          Light("directional", (0.0, 0.3, 1.0), intensity=0.3)]


def ball(center, radius, sub=3):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=sub, radius=radius)
    return np.asarray(s.vertices) + center, np.asarray(s.faces)


def scene_mesh() -> Mesh:
    v1, f1 = ball(*RECEIVER, sub=4)
    v2, f2 = ball(*OCCLUDER)
    return Mesh(np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)]))


def shadow_centre(light: Light) -> np.ndarray:
    """Where the occluder's centre projects along the light onto the receiver sphere."""
    d = -np.asarray(light.vector, float) / np.linalg.norm(light.vector)
    o = OCCLUDER[0] - RECEIVER[0]
    b = o @ d
    t = -b - np.sqrt(b * b - (o @ o - RECEIVER[1] ** 2))     # the first hit along the light
    return OCCLUDER[0] + t * d


def pixel(p, size):
    w, h = size
    vp = CAM.projection(w / h) @ CAM.view()
    c = vp @ np.r_[p, 1.0]
    ndc = c[:3] / c[3]
    return int((ndc[0] + 1) * 0.5 * w), int((1 - ndc[1]) * 0.5 * h)


def render(gl, shadow_lights, shadows="shadow_map", groom=None, **kw):
    size = (160, 120)
    r = Renderer(RenderSettings(size=size, msaa=1, shadows=shadows, shadow_lights=shadow_lights,
                                shadow_map_size=256, pcf=3, ambient=0.05, background=(0, 0, 0), **kw),
                 ctx=gl, profile=False)
    try:
        if groom is not None:
            r.set_strands(groom)
        r.set_head(scene_mesh())
        return r.render_image(CAM, LIGHTS).astype(float)
    finally:
        r.release()


def patch_mean(img, xy, r=3):
    x, y = xy
    return float(img[y - r:y + r + 1, x - r:x + r + 1].mean())


def test_two_shadow_casting_lights_darken_both_regions(gl):
    from PIL import Image

    imgs = {n: render(gl, n) for n in (1, 2)}
    none = render(gl, 1, shadows="none")
    Image.fromarray(imgs[2].astype(np.uint8)).save("/tmp/lights_two_shadows.png")
    Image.fromarray(imgs[1].astype(np.uint8)).save("/tmp/lights_one_shadow.png")
    a, b = (pixel(shadow_centre(L), (160, 120)) for L in LIGHTS[:2])
    assert a[0] < 80 < b[0]                     # light 0 (from +x) throws to -x, light 1 to +x
    lit_a, lit_b = patch_mean(none, a), patch_mean(none, b)
    assert lit_a > 40 and lit_b > 40
    # one caster: only light 0's shadow (the other light still lights each region a little)
    assert patch_mean(imgs[1], a) < 0.9 * lit_a
    assert patch_mean(imgs[1], b) > 0.98 * lit_b
    # two casters: both
    assert patch_mean(imgs[2], a) < 0.9 * lit_a
    assert patch_mean(imgs[2], b) < 0.9 * lit_b
    # elsewhere (the receiver's front, lit by both) nothing changes
    front = pixel(RECEIVER[0] + RECEIVER[1] * np.array([0.0, 0.8, 0.6]), (160, 120))
    assert 0 < front[1] < 120
    assert abs(patch_mean(imgs[2], front) - patch_mean(none, front)) < 3


def fan_over_occluder() -> Groom:
    """A tuft of hair in place of the occluding ball's top: it casts through deep opacity maps."""
    rng = np.random.default_rng(3)
    out = []
    for _ in range(40):
        x, z = rng.uniform(-0.02, 0.02, 2)
        t = np.linspace(0, 1, 6)
        out.append(np.c_[np.full_like(t, x), 0.09 - 0.05 * t, np.full_like(t, z) + 0.01 * t])
    return Groom.from_strands(out)


def test_deep_opacity_per_light(gl):
    g = fan_over_occluder()
    # single scattering: dual scattering's forward-scattered term may light a strand behind a few
    # others more than the direct lobes do (measured +19/255 on 5 pixels), so "only darkens" holds
    # for the shadow maps themselves, which is what this checks
    kw = dict(strands_per_guide=8, clump_radius=0.006, width=0.002, strand_opacity=0.5,
              shading_options={"multiple_scattering": "none"})
    one = render(gl, 1, shadows="deep_opacity", groom=g, **kw)
    two = render(gl, 2, shadows="deep_opacity", groom=g, **kw)
    diff = two - one
    # the second light's maps only darken (never brighten) and darken somewhere on the +x side
    assert diff.max() <= 2.0
    assert (diff[:, 80:] < -5).sum() > 20


def test_bad_lights_are_refused_in_one_line():
    """NaN or infinite numbers, a zero direction, a negative colour or intensity: a UsageError
    line each, before any frame is drawn (an infinite intensity had rendered a picture)."""
    from mane.errors import UsageError

    for kw, words in ((dict(vector=(np.nan, 1.0, 0.0)), "finite numbers"),
                      (dict(vector=(0.0, 0.0, 0.0)), "cannot be zero"),
                      (dict(color=(-1.0, 0.0, 0.0)), "colour must be >= 0"),
                      (dict(intensity=float("inf")), "intensity must be a finite number"),
                      (dict(intensity=-1.0), "intensity must be a finite number"),
                      (dict(kind="spot"), "light kind")):
        with pytest.raises(UsageError, match=words) as exc:
            Light(**kw)
        assert "\n" not in str(exc.value)
    assert Light(intensity=0.0).intensity == 0.0
