"""Grooming: the procedural head, follicles on meshes, procedural styles and guide strands.

    from mane.grooming import default_head, grow, make_guides, reconstruct
    head = default_head()                                  # bust with a painted scalp
    groom = grow(head, 20000, "curly", points_per_strand=32, seed=1)
    gw = make_guides(groom, 500, method="fps")             # guides + interpolation weights
"""
from __future__ import annotations

from .follicles import (  # noqa: F401
    AbovePlane,
    AllOf,
    Follicles,
    NormalCone,
    VertexColorRegion,
    frame_from_normal,
    sample_follicles,
)
from .guides import (  # noqa: F401
    GuideWeights,
    compute_guide_weights,
    make_guides,
    reconstruct,
    root_frames,
    select_guides,
)
from .head import default_head, head_sdf, scalp_faces, scalp_mask, scalp_weight  # noqa: F401
from .scene import default_scene  # noqa: F401
from .styles import PRESETS, StyleSettings, grow, style_settings  # noqa: F401


def simulation_groom(num_strands: int = 1000, style: str = "straight", points_per_strand: int = 16,
                     seed: int = 0):
    """A groom grown on the default head's scalp (a small one, sized for simulation: ``mane
    simulate default``). The rendered default scene is ``mane.grooming.scene.default_scene``."""
    return grow(default_head(), num_strands, style, points_per_strand, seed)


__all__ = [
    "default_head", "head_sdf", "scalp_weight", "scalp_mask", "scalp_faces",
    "Follicles", "sample_follicles", "frame_from_normal", "VertexColorRegion", "NormalCone",
    "AbovePlane", "AllOf", "StyleSettings", "PRESETS", "style_settings", "grow", "simulation_groom", "default_scene",
    "GuideWeights", "select_guides", "compute_guide_weights", "make_guides", "reconstruct",
    "root_frames",
]
