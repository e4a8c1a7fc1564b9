"""Reading and writing hair and mesh files: one module per format, a registry by suffix.

    groom = mane.load("model.hair")
    mane.save(groom, "model.usda")
"""
from __future__ import annotations

import importlib
import os
from pathlib import Path

from ..errors import FormatError, ManeError, UnsupportedFormatError, not_a_file
from ..groom import Groom

# suffix -> (module, can read, can write). Modules define read(path, **options) -> Groom
# and write(groom, path, **options); each is imported only when its format is used.
HAIR_FORMATS: dict[str, tuple[str, bool, bool]] = {
    ".hair": ("cyhair", True, True),
    ".data": ("usc_hairsalon", True, True),
    ".tfx": ("tressfx", True, True),
    ".tfxproj": ("tressfx", True, False),
    ".ply": ("strand_ply", True, True),
    ".abc": ("alembic_curves", True, True),
    ".usd": ("usd_curves", True, True),
    ".usda": ("usd_curves", True, True),
    ".usdc": ("usd_curves", True, True),
    ".npz": ("native_npz", True, True),
    ".bin": ("usc_hairsalon", True, False),   # CT2Hair: USC framing, 7 floats per point
}
# options a format's reader gets from mane.load (by suffix)
_READ_OPTIONS = {".bin": {"floats_per_point": 7}, ".hair": {"up": None}}

MESH_FORMATS = (".obj", ".ply", ".glb", ".gltf", ".stl", ".tfxmesh")


def _module(suffix: str, path, want: str):
    entry = HAIR_FORMATS.get(suffix)
    if entry is None or not entry[1 if want == "read" else 2]:
        can = sorted(s for s, e in HAIR_FORMATS.items() if e[1 if want == "read" else 2])
        raise UnsupportedFormatError(
            f"{path}: cannot {want} {suffix or 'files without a suffix'} hair files; "
            f"supported: {', '.join(can)}"
        )
    return importlib.import_module(f".{entry[0]}", __name__)


def load(path, units="auto", up="auto", scale=None, **options) -> Groom:
    """Read a hair file into a Groom in metres, Y up (the format is chosen by the file suffix).

    ``units`` (m, cm, mm or auto), ``up`` (x, y, z or auto: the file's up axis, turned to Y)
    and ``scale`` (metres per file unit, instead of ``units``) say what the file holds; with
    ``auto`` what the file declares is used, else its format's convention when the data fit
    it, else a guess from the data (with a warning). ``groom.metadata['frame']`` records
    which (:mod:`mane.io.units`)."""
    from .units import check_scale, check_units, check_up, normalize_groom

    units, up, scale = check_units(units), check_up(up), check_scale(scale)
    path = Path(path)
    suffix = path.suffix.lower()
    mod = _module(suffix, path, "read")
    if not path.is_file():
        raise not_a_file(path)
    options = {**_READ_OPTIONS.get(suffix, {}), **options}
    try:
        groom = mod.read(path, **options)
    except ManeError:
        raise
    except MemoryError:
        raise FormatError("the file asks for more memory than this machine has", path) from None
    except Exception as exc:  # a library underneath failed on a bad file
        raise FormatError(f"cannot read ({type(exc).__name__}: {exc})", path) from None
    groom.metadata.setdefault("source", str(path))
    return normalize_groom(groom, units, up, scale, label=path.name)


def save(groom: Groom, path, **options) -> Path:
    """Write a Groom; the format is chosen by the suffix. Returns the path written.

    A Groom is in metres, Y up; writers declare that where the format can (USD
    metersPerUnit/upAxis, .npz metadata, PLY comments, cyHair info text, TressFX reserved
    words) and keep each format's axis convention (cyHair Z-up)."""
    path = Path(path)
    mod = _module(path.suffix.lower(), path, "write")
    mod.write(groom, path, **options)
    return path


def load_mesh(path, units="auto", up="auto", scale=None, like: Groom | None = None):
    """Read a head or body mesh (OBJ, PLY, GLB/glTF, STL, TressFX .tfxmesh) in metres, Y up.

    ``units``/``up``/``scale`` as for :func:`load`. ``like``: the groom this head goes with
    (loaded by :func:`load`); a mesh stored in the groom's frame (its roots on the mesh's
    surface in stored coordinates) takes the groom's transform."""
    from .meshes import read_mesh
    from .units import frame_matrix, normalize_mesh

    path = Path(path)
    mesh = read_mesh(path)
    groom_frame = groom_raw = None
    if like is not None and isinstance(like.metadata.get("frame"), dict):
        groom_frame = like.metadata["frame"]
        import numpy as np

        groom_raw = like.transformed(np.linalg.inv(frame_matrix(groom_frame)))
    return normalize_mesh(mesh, units, up, scale, like=groom_frame, groom_raw=groom_raw, label=path.name)


def atomic_path(path: Path):
    """Context manager: a temporary path beside ``path`` that replaces it on success."""
    from .atomic import atomic_write_path

    return atomic_write_path(path)


__all__ = ["load", "save", "load_mesh", "HAIR_FORMATS", "MESH_FORMATS", "atomic_path"]
