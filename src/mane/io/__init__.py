"""Reading and writing hair and mesh files: one module per format, a registry by suffix.

    groom = mane.load("model.hair")
    mane.save(groom, "model.usda")
"""
from __future__ import annotations

import importlib
import os
from pathlib import Path

from ..errors import FormatError, ManeError, UnsupportedFormatError
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
}

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


def load(path, **options) -> Groom:
    """Read a hair file into a Groom (the format is chosen by the file suffix)."""
    path = Path(path)
    mod = _module(path.suffix.lower(), path, "read")
    if not path.is_file():
        raise FormatError("no such file", path)
    try:
        groom = mod.read(path, **options)
    except ManeError:
        raise
    except MemoryError:
        raise FormatError("the file asks for more memory than this machine has", path) from None
    except Exception as exc:  # a library underneath failed on a bad file
        raise FormatError(f"cannot read ({type(exc).__name__}: {exc})", path) from None
    groom.metadata.setdefault("source", str(path))
    return groom


def save(groom: Groom, path, **options) -> Path:
    """Write a Groom; the format is chosen by the suffix. Returns the path written."""
    path = Path(path)
    mod = _module(path.suffix.lower(), path, "write")
    mod.write(groom, path, **options)
    return path


def load_mesh(path):
    """Read a head or body mesh (OBJ, PLY, GLB/glTF, STL, TressFX .tfxmesh) as a mane Mesh."""
    from .meshes import read_mesh

    return read_mesh(Path(path))


def atomic_path(path: Path):
    """Context manager: a temporary path beside ``path`` that replaces it on success."""
    from .atomic import atomic_write_path

    return atomic_write_path(path)


__all__ = ["load", "save", "load_mesh", "HAIR_FORMATS", "MESH_FORMATS", "atomic_path"]
