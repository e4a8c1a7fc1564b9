"""settings.root_darkening: a painted occlusion toward the root, off by default. The hair's
radiance is multiplied by 1 - d (1 - smoothstep(0, 0.25, s)) (s: 0 at the root, 1 at the tip),
so with d > 0 the root is 1 - d as bright and the last three quarters of the strand are
unchanged; with 0 nothing changes anywhere (what a path tracer of the same strands sees)."""
from __future__ import annotations

import numpy as np
import pytest

from mane.bench.fidelity import realtime_linear
from mane.groom import Groom
from mane.render import Camera, Light, Renderer, RenderSettings

pytestmark = pytest.mark.gpu

SIZE = (200, 40)
CAM = Camera(eye=(0.0, 0.0, 0.3), target=(0.0, 0.0, 0.0), fov_y=10.0, near=0.05, far=3.0)
# strands along +x, root at x = -0.09 (the left of the image), 1 mm apart in y
STRANDS = [np.stack([np.linspace(-0.09, 0.09, 16), np.full(16, y), np.zeros(16)], axis=1)
           for y in np.linspace(-0.01, 0.01, 11)]


@pytest.fixture(scope="module", params=["compute", "hardware"])
def images(gl, request):
    def one(darkening):
        settings = RenderSettings(size=SIZE, rasterizer=request.param, msaa=4, shadows="none", ambient=0.0,
                                  background=(0, 0, 0), tone_mapping="none", exposure=1.0, strands_per_guide=1,
                                  strand_spread=0.0, width=0.0005, width_tip=1.0, draw_head=False,
                                  root_darkening=darkening)
        r = Renderer(settings, ctx=gl, profile=False)
        try:
            r.set_strands(Groom.from_strands(STRANDS))
            return realtime_linear(r, CAM, [Light("directional", (0.0, 0.3, 1.0), intensity=2.0)])
        finally:
            r.release()

    return {d: one(d) for d in (0.0, 0.5)}


def _columns(img):
    """Summed luminance of each image column (the strands run along x)."""
    return (img[..., :3] @ np.array([0.2126, 0.7152, 0.0722])).sum(axis=0)


def test_root_darkening_scales_the_root_and_leaves_the_rest(images):
    plain, dark = _columns(images[0.0]), _columns(images[0.5])
    lit = np.nonzero(plain > 0.2 * plain.max())[0]
    x0, x1 = lit.min(), lit.max()                  # the root's and the tip's columns
    span = x1 - x0
    assert span > 100
    ratio = dark / np.maximum(plain, 1e-12)
    root = ratio[x0 + 1: x0 + 4]
    assert np.all(np.abs(root - 0.5) < 0.03), root            # 1 - d at the root
    rest = ratio[x0 + int(0.3 * span): x1 - 1]
    assert np.all(np.abs(rest - 1.0) < 1e-3), rest.min()     # untouched past a quarter


def test_root_darkening_defaults_to_none():
    assert RenderSettings().root_darkening == 0.0
