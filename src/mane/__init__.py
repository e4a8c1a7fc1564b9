"""mane: real-time hair simulation and rendering on the GPU.

    import mane
    groom = mane.load("hair.tfx")        # any supported hair file, in metres, Y up
    print(groom.stats())
    mane.save(groom, "hair.usda")        # declares metres and Y up
    img = mane.render_image(groom)       # (H, W, 3) uint8; as_pil=True: a PIL image for notebooks
"""
from __future__ import annotations

__version__ = "0.1.0"

from .errors import (  # noqa: F401
    FormatError,
    GLFeatureError,
    GPUError,
    GPUMemoryError,
    GroomError,
    ManeError,
    ShaderCompileError,
    UnsupportedFormatError,
    UsageError,
)
from .groom import Groom  # noqa: F401
from .io import load, load_mesh, save  # noqa: F401



def __getattr__(name):
    # mane.render_image loads the renderer (moderngl) only when asked for: ``import mane`` stays light
    if name == "render_image":
        from .render.image import render_image

        return render_image
    if name == "warm_up":   # a scene's GPU programs compiled ahead (mane.warmup)
        from .warmup import warm_up

        return warm_up
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "__version__", "Groom", "load", "save", "load_mesh", "render_image", "warm_up",
    "ManeError", "FormatError", "UnsupportedFormatError", "GroomError", "UsageError",
    "GPUError", "GLFeatureError", "ShaderCompileError", "GPUMemoryError",
]
