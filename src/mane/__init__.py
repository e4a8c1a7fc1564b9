"""mane: real-time hair simulation and rendering on the GPU.

    import mane
    groom = mane.load("hair.tfx")        # any supported hair file
    print(groom.stats())
    mane.save(groom.scaled(0.01), "hair.usda")
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

__all__ = [
    "__version__", "Groom", "load", "save", "load_mesh",
    "ManeError", "FormatError", "UnsupportedFormatError", "GroomError", "UsageError",
    "GPUError", "GLFeatureError", "ShaderCompileError", "GPUMemoryError",
]
