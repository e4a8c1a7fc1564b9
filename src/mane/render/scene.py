"""The procedural default scene: grooming's default head and long wavy hair grown on its scalp."""
from __future__ import annotations

from functools import lru_cache

from ..groom import Groom

DEFAULT_STYLE = "long_wavy"


@lru_cache(maxsize=4)
def _head(subdivisions: int):
    from ..grooming.head import default_head

    return default_head(subdivisions)


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
    from ..grooming import grow

    head = head if head is not None else default_head()
    return grow(head, num_strands=num_guides, style=style, points_per_strand=points, seed=seed,
                blue_noise=True)


def default_scene(num_guides: int = 600, points: int = 16, subdivisions: int = 5):
    """(groom, head) of the procedural default."""
    head = default_head(subdivisions)
    return default_groom(head, num_guides, points), head


DEFAULT_SCENE_RENDER = dict(clump_root=0.7)
"""RenderSettings the default scene is rendered with (``mane render``, ``mane demo``,
``render_image()`` without a groom): each guide's clump of rendered strands starts 0.7 of
``clump_radius`` (4.2 mm) wide at the root instead of 0.25 (1.5 mm), so the clumps of 1000
guides about 8 mm apart meet on the scalp (1.5 mm clumps 8 mm apart read as comb teeth along
the hairline and the parting, with scalp between)."""


def default_render_settings(settings=None, **changes):
    """``settings`` (default ``RenderSettings()``) with the default scene's ``DEFAULT_SCENE_RENDER``
    and then ``changes``."""
    from .settings import RenderSettings

    base = settings if settings is not None else RenderSettings()
    return base.replace(**{**DEFAULT_SCENE_RENDER, **changes})


SINTEL_CREDIT = "Sintel: (c) Blender Foundation, CC BY 3.0"
SINTEL_STRANDS_PER_GUIDE = 64
"""Sintel's 228 strands are guides: 64 rendered strands each (14,592) fill her hair out."""


def sintel_scene(data_dir):
    """(groom, head) of Sintel's TressFX groom on her bust from ``data_dir`` (a folder holding
    ``tressfx/sintel_hair.tfx`` and ``heads/sintel.obj``, in centimetres: scaled to metres).

    The files are not part of mane (CC BY 3.0, Blender Foundation); a missing file is a
    ``GroomError`` that names it."""
    from pathlib import Path

    from ..errors import GroomError
    from ..io import load, load_mesh

    root = Path(data_dir)
    hair, bust = root / "tressfx" / "sintel_hair.tfx", root / "heads" / "sintel.obj"
    for f in (hair, bust):
        if not f.is_file():
            raise GroomError(f"Sintel's scene needs {f}, which is not there")
    groom = load(hair, units="cm", up="y")            # TressFX: centimetres, Y up
    head = load_mesh(bust, units="cm", up="y")        # her bust, in the same frame
    return groom, head


def sintel_render_settings(**changes):
    """RenderSettings for Sintel at full density: clumps sized for her 228 guides."""
    from .settings import RenderSettings

    base = dict(strands_per_guide=SINTEL_STRANDS_PER_GUIDE, clump_radius=0.012, clump_tip=0.6,
                width=0.0004)
    base.update(changes)
    return RenderSettings(**base)
