"""Back-face culling of the head: only for a closed mesh wound counter-clockwise from outside
(Mesh.closed_outward, from the mesh's edges and signed volume), and then the same picture."""
from __future__ import annotations

import numpy as np
import pytest

from mane.grooming.head import default_head, icosphere
from mane.mesh import Mesh


def _sphere() -> Mesh:
    v, f = icosphere(2)
    return Mesh(v * 0.1, f)


def test_closed_outward_from_edges_and_volume():
    m = _sphere()
    assert m.closed_outward()                                    # closed, outward: volume > 0
    assert not Mesh(m.vertices, m.faces[:, ::-1]).closed_outward()   # wound inward: volume < 0
    assert not Mesh(m.vertices, m.faces[1:]).closed_outward()        # a hole: 3 boundary edges
    flipped = m.faces.copy()
    flipped[0] = flipped[0, ::-1]                                    # one face against its neighbours
    assert not Mesh(m.vertices, flipped).closed_outward()
    doubled = np.concatenate([m.faces, m.faces[:1]])                 # a face twice: non-manifold
    assert not Mesh(m.vertices, doubled).closed_outward()
    assert default_head().closed_outward()                           # the packaged head: culled


@pytest.mark.gpu
def test_culled_head_is_the_same_picture(gl):
    from mane.render import Renderer, RenderSettings
    from mane.render.camera import Camera

    head = default_head()
    s = RenderSettings(size=(96, 96), shadows="shadow_map", shadow_map_size=128, draw_head=True)
    images = []
    for cull in (True, False):
        r = Renderer(s, ctx=gl, profile=False)
        try:
            r.set_head(head)
            assert r.head_closed
            r.head_closed = cull
            lo, hi = head.bbox()
            c = (lo + hi) / 2
            for eye in (c + (0.0, 0.05, 0.6), c + (0.5, 0.1, -0.3)):     # front, back-side
                r.render(Camera(eye=tuple(eye), target=tuple(c), fov_y=40.0, near=0.05, far=3.0))
                images.append(r.read_image().astype(int))
        finally:
            r.release()
    for a, b in zip(images[:2], images[2:]):
        assert a.std() > 5                                           # the head is in the picture
        assert np.abs(a - b).max() <= 1


@pytest.mark.gpu
@pytest.mark.parametrize("azimuth", [0.0, 140.0])
def test_culled_head_casts_the_same_shadow_map(gl, azimuth):
    from mane.render import Renderer, RenderSettings

    head = default_head()
    maps = []
    for cull in (True, False):
        r = Renderer(RenderSettings(size=(64, 64), shadows="shadow_map", shadow_map_size=128), ctx=gl, profile=False)
        try:
            r.set_head(head)
            r.head_closed = cull
            r.render(r.default_camera(azimuth))
            maps.append(r.get_pass("shadow_map").read())
        finally:
            r.release()
    assert (maps[0] < 1e8).mean() > 0.1                             # the head fills part of the map
    # the same map but where a silhouette texel's centre falls between a front and a back face
    # at the rasteriser's rounding (1 of 16384 here): there the two agree within a millimetre
    differ = maps[0] != maps[1]
    assert differ.mean() < 1e-3
    np.testing.assert_allclose(maps[0][differ], maps[1][differ], atol=1e-3)
