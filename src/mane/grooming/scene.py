"""The procedural default scene: the default head (cached) and long wavy hair grown on its scalp.

    from mane.grooming.scene import default_scene
    groom, head = default_scene(num_guides=600, points=16)
"""
from __future__ import annotations

from functools import lru_cache

from ..groom import Groom
from .head import default_head as _make_head
from .styles import grow

DEFAULT_STYLE = "long_wavy"


@lru_cache(maxsize=4)
def _head(subdivisions: int):
    return _make_head(subdivisions)


def default_head(subdivisions: int = 5):
    """The default bust (cached per subdivision level; 5 gives 20,480 triangles: enough for the
    lips, nose and eyes)."""
    return _head(int(subdivisions))


def default_groom(head=None, num_guides: int = 600, points: int = 16, style: str = DEFAULT_STYLE,
                  seed: int = 0) -> Groom:
    """``num_guides`` guide strands of ``points`` points grown on the head's scalp, their roots
    spread by blue noise: uniform random roots left holes (5% of the scalp farther than 8 mm
    from any of 1000 roots, against 0.3%) that the rendered clumps around each guide showed as
    bald patches."""
    head = head if head is not None else default_head()
    return grow(head, num_strands=num_guides, style=style, points_per_strand=points, seed=seed,
                blue_noise=True)


def default_scene(num_guides: int = 600, points: int = 16, subdivisions: int = 5):
    """(groom, head) of the procedural default."""
    head = default_head(subdivisions)
    return default_groom(head, num_guides, points), head


DEFAULT_SCENE_RENDER = dict(clump_root=0.7)
"""RenderSettings fields the default scene is rendered with (``mane render``, ``mane demo``,
``render_image()`` without a groom): each guide's clump of rendered strands starts 0.7 of
``clump_radius`` (4.2 mm) wide at the root instead of 0.25 (1.5 mm), so the clumps of 1000
guides about 8 mm apart meet on the scalp (1.5 mm clumps 8 mm apart read as comb teeth along
the hairline and the parting, with scalp between). Plain data: grooming sits below render."""
