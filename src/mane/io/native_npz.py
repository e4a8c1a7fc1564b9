"""mane's own ``.npz``: every Groom array and attribute, exactly, in a NumPy zip archive.

Members (each an ``.npy`` inside the zip):

==========================  ==========================================================
``format_version``          int64 scalar, 1
``points``                  (P, 3) float32
``counts``                  (S,) int32
``widths``                  optional (P,) float32
``colors``                  optional (P, 3) float32
``transparency``            optional (P,) float32
``point:NAME``              a point attribute: first axis P, bool / int / uint / float
``strand:NAME``             a strand attribute: first axis S
``metadata``                0-d unicode string: the metadata dict as JSON
==========================  ==========================================================

The metadata declares ``units: "m"`` and ``up_axis: "y"`` (a Groom's frame); reading a file
that says so guesses nothing (:mod:`mane.io.units`). Reading never unpickles: object and structured dtypes are refused, and the arrays are built
with ``np.frombuffer`` from each member's bytes after its ``.npy`` header has been checked
against the member's size (so a header cannot make the reader allocate more than is there).
"""
from __future__ import annotations

import io
import json
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ..errors import FormatError, GroomError
from ..groom import Groom
from .atomic import atomic_write_path

FORMAT_VERSION = 1
_CORE = {"points": (np.float32, (3,)), "counts": (np.int32, ()), "widths": (np.float32, ()),
         "colors": (np.float32, (3,)), "transparency": (np.float32, ())}
_MAX_MEMBERS = 4096


MIN_MEMBER_LIMIT = 64 << 20
"""Decompressed bytes always accepted; beyond it at most MAX_RATIO times the file's size."""
MAX_RATIO = 64
"""Largest decompressed / compressed ratio accepted in all (mane's grooms compress ~1.1-3x;
a zip bomb ~1000x)."""


def _member_limit(file_size: int) -> int:
    """The most decompressed bytes accepted in all (zip bombs stop here, before any is read)."""
    return max(MIN_MEMBER_LIMIT, MAX_RATIO * file_size)


def _read_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, path) -> np.ndarray:
    name = info.filename
    # the .npy header first: the array it declares must be the member's declared size, checked
    # before the rest is decompressed
    with zf.open(info) as fh:
        head = fh.read(min(info.file_size, 1 << 16))
        bio = io.BytesIO(head)
        try:
            version = np.lib.format.read_magic(bio)
            reader = {(1, 0): np.lib.format.read_array_header_1_0}.get(version, np.lib.format.read_array_header_2_0)
            shape, _, dtype = reader(bio)
            count = int(np.prod(shape, dtype=object)) if shape else 1
            want = bio.tell() + count * dtype.itemsize
            if dtype.hasobject or dtype.fields is not None or dtype.kind not in "biufU":
                want = None   # refused below with its own reason
        except Exception:
            want = None   # the full parse below reports it
        if want is not None and want != info.file_size:
            raise FormatError(f"member {name!r}: its header declares {want} bytes but the archive says "
                              f"{info.file_size}", path)
        raw = head + fh.read(max(info.file_size - len(head), 0))
    bio = io.BytesIO(raw)
    try:
        version = np.lib.format.read_magic(bio)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(bio)
        elif version in ((2, 0), (3, 0)):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(bio)
        else:
            raise ValueError(f"unknown .npy version {version}")
    except (ValueError, SyntaxError, TypeError, EOFError, MemoryError, RecursionError) as exc:
        raise FormatError(f"member {name!r}: bad .npy header ({str(exc)[:200]})", path) from None
    if dtype.hasobject or dtype.fields is not None or dtype.subdtype is not None:
        raise FormatError(f"member {name!r}: dtype {dtype} is not allowed (no objects, no records)", path)
    if dtype.kind not in "biufU":
        raise FormatError(f"member {name!r}: dtype {dtype} is not allowed", path)
    if any((not isinstance(d, int)) or d < 0 for d in shape):
        raise FormatError(f"member {name!r}: bad shape {shape}", path)
    count = int(np.prod(shape, dtype=object)) if shape else 1
    start = bio.tell()
    if count * dtype.itemsize != len(raw) - start:
        raise FormatError(
            f"member {name!r}: its header declares {shape} {dtype} ({count * dtype.itemsize} bytes) "
            f"but it holds {len(raw) - start} bytes", path)
    arr = np.frombuffer(raw, dtype=dtype, count=count, offset=start)
    arr = arr.reshape(shape, order="F" if fortran else "C")
    return arr.astype(dtype.newbyteorder("="), order="C", copy=True)


def read(path, **options) -> Groom:
    """Read a mane ``.npz``; anything unknown, ill-shaped or hostile is a FormatError."""
    if options:
        raise FormatError(f"unknown options for .npz: {sorted(options)}", path)
    path = Path(path)
    try:
        size = path.stat().st_size
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, EOFError, OSError,
            NotImplementedError, struct.error) as exc:
        raise FormatError(f"not a valid .npz (zip) archive ({str(exc)[:200]})", path) from None
    arrays: dict[str, np.ndarray] = {}
    with zf:
        try:
            infos = zf.infolist()
            if len(infos) > _MAX_MEMBERS:
                raise FormatError(f"{len(infos)} members is too many", path)
            total = sum(max(i.file_size, 0) for i in infos)
            if total > _member_limit(size):
                raise FormatError(
                    f"the archive declares {total} decompressed bytes for a {size}-byte file; refused",
                    path)
            for info in infos:
                name = info.filename
                if not name.endswith(".npy"):
                    raise FormatError(f"unexpected member {name!r} (a mane .npz holds only .npy arrays)",
                                      path)
                key = name[:-4]
                if key in arrays:
                    raise FormatError(f"member {name!r} appears twice", path)
                if not (key in _CORE or key in ("metadata", "format_version")
                        or (key.startswith(("point:", "strand:")) and len(key.split(":", 1)[1]) > 0)):
                    raise FormatError(f"unknown member {name!r}", path)
                arrays[key] = _read_member(zf, info, path)
        except FormatError:
            raise
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError,
                RuntimeError, struct.error) as exc:
            raise FormatError(f"corrupt archive ({type(exc).__name__}: {str(exc)[:200]})", path) from None
    return _groom_from_arrays(arrays, path)


def _groom_from_arrays(arrays: dict[str, np.ndarray], path) -> Groom:
    version = arrays.pop("format_version", None)
    if version is not None:
        if version.shape != () or version.dtype.kind not in "iu" or int(version) != FORMAT_VERSION:
            raise FormatError(f"unsupported mane .npz format_version {version!r}", path)
    for key in ("points", "counts"):
        if key not in arrays:
            raise FormatError(f"missing member {key!r}", path)
    core = {}
    for key, (dtype, tail) in _CORE.items():
        if key not in arrays:
            continue
        a = arrays.pop(key)
        if a.ndim != 1 + len(tail) or a.shape[1:] != tail:
            raise FormatError(f"{key}: expected shape (N{''.join(', ' + str(t) for t in tail)}), "
                              f"got {a.shape}", path)
        want = np.dtype(dtype)
        if a.dtype != want:
            if key == "counts" and a.dtype.kind in "iu":
                if a.size and (a.min() < 0 or a.max() > np.iinfo(np.int32).max):
                    raise FormatError("counts out of range", path)
            elif a.dtype.kind != "f" or key == "counts":
                raise FormatError(f"{key}: dtype {a.dtype}, expected {want}", path)
            a = a.astype(want)
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            raise FormatError(f"{key} contains NaN or infinite values", path)
        core[key] = a
    metadata = {}
    if "metadata" in arrays:
        m = arrays.pop("metadata")
        if m.shape != () or m.dtype.kind != "U":
            raise FormatError("metadata must be a 0-d string", path)
        try:
            metadata = json.loads(str(m))
        except (ValueError, RecursionError) as exc:
            raise FormatError(f"metadata is not valid JSON ({str(exc)[:100]})", path) from None
        if not isinstance(metadata, dict):
            raise FormatError("metadata must be a JSON object", path)
    if metadata.get("units") == "m" and metadata.get("up_axis") == "y":  # written by mane: declared
        metadata["file_frame"] = {"units": "m", "units_source": "declared", "up": "y", "up_source": "declared"}
    point_attributes, strand_attributes = {}, {}
    for key, a in arrays.items():
        kind, name = key.split(":", 1)
        if a.dtype.kind == "U":
            raise FormatError(f"{key}: string attributes are not allowed", path)
        (point_attributes if kind == "point" else strand_attributes)[name] = a
    try:
        return Groom(core["points"], core["counts"], widths=core.get("widths"),
                     colors=core.get("colors"), transparency=core.get("transparency"),
                     point_attributes=point_attributes, strand_attributes=strand_attributes,
                     metadata=metadata)
    except GroomError as exc:
        raise FormatError(str(exc), path) from None


def write(groom: Groom, path, compress: bool = True) -> None:
    """Write every array and attribute of ``groom``; metadata goes in as JSON."""
    arrays = {"format_version": np.array(FORMAT_VERSION, dtype=np.int64),
              "points": groom.points, "counts": groom.counts}
    for key in ("widths", "colors", "transparency"):
        value = getattr(groom, key)
        if value is not None:
            arrays[key] = value
    for prefix, attrs in (("point", groom.point_attributes), ("strand", groom.strand_attributes)):
        for name, value in attrs.items():
            value = np.asarray(value)
            if value.dtype.kind not in "biuf":
                raise GroomError(f"{prefix} attribute {name!r}: dtype {value.dtype} cannot be saved")
            arrays[f"{prefix}:{name}"] = value
    try:  # a Groom is in metres, Y up: declared so that reading it back guesses nothing
        meta = json.dumps({**groom.metadata, "units": "m", "up_axis": "y"}, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise GroomError(f"metadata is not JSON-serialisable: {exc}") from None
    arrays["metadata"] = np.array(meta)
    save = np.savez_compressed if compress else np.savez
    with atomic_write_path(path) as tmp:
        with open(tmp, "wb") as fh:
            save(fh, **arrays)
