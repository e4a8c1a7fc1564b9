"""The head mesh follows the simulator's rigid head motion (``Renderer.set_head_transform``)."""
import numpy as np
import pytest

from mane import Groom, UsageError
from mane.render import Renderer, RenderSettings
from mane.grooming.scene import default_head


def _skin_centroid(img: np.ndarray, background: np.ndarray) -> np.ndarray:
    mask = np.abs(img.astype(float) - background).sum(axis=2) > 30
    ys, xs = np.nonzero(mask)
    return np.array([xs.mean(), ys.mean()])


def test_head_moves_with_its_transform(gl):
    head = default_head(3)
    # one short strand on top of the head so the renderer has hair to frame
    groom = Groom(np.array([[0, 0.11, 0], [0, 0.12, 0.01]], np.float32), [2])
    r = Renderer(RenderSettings(size=(160, 120), shadows="none", msaa=1), ctx=gl)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = r.default_camera(0.0, 0.0)
        still = r.render_image(cam, None)
        background = still[0, 0].astype(float)
        shift = np.eye(4)
        shift[:3, 3] = (0.05, 0.0, 0.0)
        r.set_head_transform(shift)
        moved = r.render_image(cam, None)
        # where the camera puts +x on screen: project two points through its view-projection
        vp = cam.view_projection(160 / 120)
        a, b = (vp @ np.array([0, 0, 0, 1.0])), (vp @ np.array([0.05, 0, 0, 1.0]))
        expected = np.sign(b[0] / b[3] - a[0] / a[3])
        dx = _skin_centroid(moved, background)[0] - _skin_centroid(still, background)[0]
        assert np.sign(dx) == expected and abs(dx) > 2
        with pytest.raises(UsageError):
            r.set_head_transform(np.full((4, 4), np.nan))
    finally:
        r.release()
