"""One call from a groom to a picture.

    img = render_image(groom, head=mesh, size=(320, 240), shadows="deep_opacity")   # (H, W, 3) uint8
    img = render_image()                                # the procedural default head and groom
"""
from __future__ import annotations

import numpy as np

from .camera import Camera
from .renderer import Renderer
from .settings import RenderSettings


def render_image(groom=None, head=None, *, settings: RenderSettings | None = None, camera: Camera | None = None,
                 lights=None, ctx=None, azimuth: float = 25.0, elevation: float = 12.0, **overrides) -> np.ndarray:
    """Render ``groom`` (a Groom, StrandBuffers or Simulator; None: the default scene) and ``head``.

    ``overrides`` are RenderSettings fields (size=(w, h), shadows=..., msaa=...)."""
    settings = (settings or RenderSettings()).replace(**overrides) if overrides else (settings or RenderSettings())
    if groom is None:
        from .scene import default_scene

        groom, default = default_scene()
        head = head if head is not None else default
    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = camera if camera is not None else r.default_camera(azimuth, elevation)
        return r.render_image(cam, lights)
    finally:
        r.release()
