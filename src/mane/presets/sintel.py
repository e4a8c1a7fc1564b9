"""Sintel's scene (Blender Foundation, CC BY 3.0): her TressFX groom on her bust, from files that are
not part of mane, and the render settings that fill her 228 guides out."""
from __future__ import annotations

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
    from ..render.settings import RenderSettings

    base = dict(strands_per_guide=SINTEL_STRANDS_PER_GUIDE, clump_radius=0.012, clump_tip=0.6,
                width=0.0004)
    base.update(changes)
    return RenderSettings(**base)
