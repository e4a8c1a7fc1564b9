"""One call from a groom to a picture.

    img = render_image(groom, head=mesh, size=(320, 240), shadows="deep_opacity")   # (H, W, 3) uint8
    img = render_image()                                # the procedural default head and groom
    pic = render_image(groom, as_pil=True)              # a PIL image: shows itself in Jupyter
"""
from __future__ import annotations

import numpy as np

from .camera import Camera
from .renderer import Renderer
from .settings import RenderSettings


def render_image(groom=None, head=None, *, settings: RenderSettings | None = None, camera: Camera | None = None,
                 lights=None, ctx=None, azimuth: float = 25.0, elevation: float = 12.0, as_pil: bool = False,
                 **overrides):
    """Render a still picture of ``groom`` (a Groom, StrandBuffers or Simulator; None: the
    default scene) and ``head``: the mean of ``settings.accumulate`` frames (Renderer.render_still).

    ``overrides`` are RenderSettings fields (size=(w, h), shadows=..., msaa=...). Returns an
    (H, W, 3) uint8 array, or with ``as_pil=True`` a ``PIL.Image.Image`` (which a Jupyter
    notebook displays: it has ``_repr_png_``)."""
    given = settings is not None
    settings = (settings or RenderSettings()).replace(**overrides) if overrides else (settings or RenderSettings())
    if groom is None:
        from ..grooming.scene import DEFAULT_SCENE_RENDER, default_scene

        groom, default = default_scene()
        head = head if head is not None else default
        if not given:   # the default scene's clumps, unless asked otherwise
            settings = settings.replace(**{k: v for k, v in DEFAULT_SCENE_RENDER.items() if k not in overrides})
    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = camera if camera is not None else r.default_camera(azimuth, elevation)
        image = r.render_still(cam, lights)
    finally:
        r.release()
    if as_pil:
        from PIL import Image

        return Image.fromarray(image)
    return image
