"""The procedural default scene: grooming's default head and long wavy hair grown on its scalp."""
from __future__ import annotations

from functools import lru_cache

from ..groom import Groom

DEFAULT_STYLE = "long_wavy"


@lru_cache(maxsize=4)
def _head(subdivisions: int):
    from ..grooming.head import default_head

    return default_head(subdivisions)


def default_head(subdivisions: int = 4):
    """The default bust (cached per subdivision level; 4 gives 5,120 triangles)."""
    return _head(int(subdivisions))


def default_groom(head=None, num_guides: int = 600, points: int = 16, style: str = DEFAULT_STYLE,
                  seed: int = 0) -> Groom:
    """``num_guides`` guide strands of ``points`` points grown on the head's scalp."""
    from ..grooming import grow

    head = head if head is not None else default_head()
    return grow(head, num_strands=num_guides, style=style, points_per_strand=points, seed=seed)


def default_scene(num_guides: int = 600, points: int = 16, subdivisions: int = 4):
    """(groom, head) of the procedural default."""
    head = default_head(subdivisions)
    return default_groom(head, num_guides, points), head
