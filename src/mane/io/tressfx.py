"""AMD TressFX hair: binary ``.tfx`` (versions 4 and 3) and the ASCII ``.tfxproj`` project.

Every strand of a ``.tfx`` file has the same number of vertices. Little-endian.

Version 4 (``float32 version`` is 4.0), a 160-byte header::

    0   float32 version
    4   uint32  numHairStrands
    8   uint32  numVerticesPerStrand      (4..64, a power of two, in AMD's tools)
    12  uint32  offsetVertexPosition      float32x4 [strands*verts]; w == 0: immovable vertex
    16  uint32  offsetStrandUV            float32x2 [strands], 0 = absent
    20  uint32  offsetVertexUV            float32x2 [strands*verts], 0 = absent
    24  uint32  offsetStrandThickness     float32   [strands], 0 = absent
    28  uint32  offsetVertexColor         float32x4 [strands*verts], 0 = absent
    32  uint32  reserved[32]

Offsets are bytes from the start of the file. Version 3 (``version`` 3.0), a 296-byte
header: ``float32 version; uint32 numGuideHairStrands, numVerticesPerStrand,
numFollowHairsPerGuideHair, bothEndsImmovable, reserved1[31]``, then at byte 144 six uint32
offsets (vertices ``float32x3[strands*verts]``, per-strand thickness ``float32[strands]``,
per-strand texcoord ``float32x2[strands]``, per-vertex colour, guide-hair index, per-vertex
texcoord) and ``reserved2[32]``. Version 3 has no w: TressFX 3's loader
(``TressFXAssetLoader::LoadAppend``) makes the first two vertices of every strand immovable,
and the last two as well when ``bothEndsImmovable`` is set; mane does the same.

What mane keeps: points; the bool point attribute ``immovable``; per-strand UVs as the strand
attribute ``uv`` (S, 2); per-vertex UVs as the point attribute ``uv`` (P, 2); per-strand
thickness coefficients as the strand attribute ``thickness`` (relative: TressFX multiplies them
by a fibre radius, so they are not ``widths``); vertex colours as ``colors`` and
``transparency = 1 - alpha`` (left out when every alpha is 1). The v3 per-vertex colour,
guide-hair and per-vertex texcoord arrays are not read (their layout is not pinned down by any
real file) and are listed in ``metadata['tressfx']['ignored_arrays']``.

Units and axes: TressFX grooms are centimetres, Y-up by convention (AMD's samples); the
numbers are returned as stored with that convention in ``metadata['file_frame']`` for
:mod:`mane.io.units`. mane's writer puts ``b"mane"``, the unit (``b"m"``) and the up axis
(``b"y"``) in the first three words of the v4 header's ``reserved`` block (readers ignore
them) and reads them back as a declaration.

``.tfxproj`` (TressFX 3 samples) is a text project: ``#`` comments, ``Version``,
``project_name``, one line per hair part ``FILE.tfx followHairs radius tipSeparation
SIM.tfxsim [section name]`` (paths relative to the project), a mesh file name, and settings
(``collision_sphere x y z r`` up to 3 times, ``hairColor r g b``, numbers). Reading one gives
the concatenated parts (strand attribute ``part``) and the settings in
``metadata['tressfx_project']``.

:func:`write` writes version 4, resampling the strands to a power of two (4..64) vertices.
Without an ``immovable`` attribute the root of every strand is written immovable.
"""
from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np

from ..errors import FormatError, GroomError, UsageError
from ..groom import Groom
from .atomic import atomic_write_path
from .binary import Cursor, read_file_bytes

V4_HEADER_SIZE = 160
V3_HEADER_SIZE = 296
MAX_VERTICES_PER_STRAND = 4096
MAX_PROJECT_BYTES = 1 << 20
MAX_PROJECT_PARTS = 256
MAX_PROJECT_TOTAL_BYTES = 256 << 20
"""Most bytes of .tfx parts one project may pull in, all parts together (the largest TressFX
sample projects are a few MB; 256 mentions of one big part would otherwise read it 256 times)."""


def read(path, **options) -> Groom:
    """Read a ``.tfx`` (v3 or v4) or a ``.tfxproj``, chosen by the suffix."""
    path = Path(path)
    if options:
        raise FormatError(f"unknown options for TressFX: {sorted(options)}", path)
    if path.suffix.lower() == ".tfxproj":
        return read_project(path)
    return read_tfx(path)


def read_tfx(path) -> Groom:
    path = Path(path)
    data = read_file_bytes(path)
    cur = Cursor(data, path)
    version = cur.f32("the version")
    if 4.0 <= version < 5.0:  # 4.0 in every known file; 4.x kept the layout
        return _read_v4(cur)
    if 3.0 <= version < 4.0:
        return _read_v3(cur)
    raise FormatError(f"not a TressFX file, or an unsupported version ({version!r}; "
                      "mane reads versions 3 and 4)", path, 0)


def _counts(cur: Cursor, strands: int, verts: int, vertex_bytes: int, header: int):
    path = cur.path
    if strands == 0:
        raise FormatError("the file holds no strands (numHairStrands is 0)", path, 4)
    if not 2 <= verts <= MAX_VERTICES_PER_STRAND:
        raise FormatError(f"numVerticesPerStrand is {verts}; it must be 2..{MAX_VERTICES_PER_STRAND}",
                          path, 8)
    if strands * verts * vertex_bytes > len(cur.data) - header:
        raise FormatError(
            f"truncated: the header declares {strands} strands x {verts} vertices "
            f"({strands * verts * vertex_bytes} bytes of positions) but the file has "
            f"{max(len(cur.data) - header, 0)} bytes after the header", path, 4)


def _array_at(cur: Cursor, offset: int, header: int, dtype: str, count: int, width: int,
              what: str, field_offset: int) -> np.ndarray:
    if offset < header:
        raise FormatError(f"{what} offset {offset} points into the header", cur.path, field_offset)
    arr = cur.array(dtype, count * width, what, offset=offset, finite=True)
    return arr.reshape(-1, width) if width > 1 else arr


def _read_v4(cur: Cursor) -> Groom:
    path = cur.path
    cur.need(V4_HEADER_SIZE - 4, "the 160-byte version 4 header")
    strands, verts, o_pos, o_suv, o_vuv, o_thick, o_col = cur.unpack("<7I", "header")
    _counts(cur, strands, verts, 16, V4_HEADER_SIZE)
    P = strands * verts
    if o_pos == 0:
        raise FormatError("offsetVertexPosition is 0: the file has no positions", path, 12)
    pos = _array_at(cur, o_pos, V4_HEADER_SIZE, "<f4", P, 4, "vertex positions", 12)
    strand_attrs, point_attrs = {}, {"immovable": pos[:, 3] == 0.0}
    colors = transparency = None
    present = ["positions"]
    if o_suv:
        strand_attrs["uv"] = _array_at(cur, o_suv, V4_HEADER_SIZE, "<f4", strands, 2, "strand UVs", 16)
        present.append("strand_uv")
    if o_vuv:
        point_attrs["uv"] = _array_at(cur, o_vuv, V4_HEADER_SIZE, "<f4", P, 2, "vertex UVs", 20)
        present.append("vertex_uv")
    if o_thick:
        strand_attrs["thickness"] = _array_at(cur, o_thick, V4_HEADER_SIZE, "<f4", strands, 1,
                                              "strand thickness", 24)
        present.append("strand_thickness")
    if o_col:
        rgba = _array_at(cur, o_col, V4_HEADER_SIZE, "<f4", P, 4, "vertex colours", 28)
        colors = rgba[:, :3]
        if not np.all(rgba[:, 3] == 1.0):
            transparency = 1.0 - rgba[:, 3]
        present.append("vertex_color")
    meta = {
        "format": "TressFX",
        "tressfx": {"version": 4, "num_strands": strands, "vertices_per_strand": verts,
                    "arrays": present, "immovable_vertices": int(point_attrs["immovable"].sum())},
        "up_axis": "y",
        "units": "as stored",
        "file_frame": _frame(cur.data),
    }
    return _groom(path, pos[:, :3], strands, verts, colors, transparency, point_attrs,
                  strand_attrs, meta)


CONVENTION = {"units": "cm", "units_source": "convention", "up": "y", "up_source": "convention"}
MARK = b"mane"


def _frame(data: bytes) -> dict:
    """The v4 header's mane marker (reserved words 0-2) as a declaration, else the convention."""
    if data[32:36] == MARK:
        units = data[36:40].rstrip(b"\0").decode("ascii", "replace")
        up = data[40:44].rstrip(b"\0").decode("ascii", "replace")
        if units in ("m", "cm", "mm") and up in ("x", "y", "z"):
            return {"units": units, "units_source": "declared", "up": up, "up_source": "declared"}
    return dict(CONVENTION)


def _read_v3(cur: Cursor) -> Groom:
    path = cur.path
    cur.need(V3_HEADER_SIZE - 4, "the 296-byte version 3 header")
    strands, verts, follow, both_ends = cur.unpack("<4I", "header")
    cur.pos = 144
    o_vert, o_thick, o_suv, o_col, o_guide, o_vuv = cur.unpack("<6I", "offsets")
    _counts(cur, strands, verts, 12, V3_HEADER_SIZE)
    P = strands * verts
    if o_vert == 0:
        raise FormatError("the vertices offset is 0: the file has no positions", path, 144)
    pos = _array_at(cur, o_vert, V3_HEADER_SIZE, "<f4", P, 3, "vertex positions", 144)
    j = np.tile(np.arange(verts), strands)
    immovable = j < 2
    if both_ends:
        immovable |= j >= verts - 2
    strand_attrs = {}
    present = ["vertices"]
    if o_thick:
        strand_attrs["thickness"] = _array_at(cur, o_thick, V3_HEADER_SIZE, "<f4", strands, 1,
                                              "strand thickness", 148)
        present.append("strand_thickness")
    if o_suv:
        strand_attrs["uv"] = _array_at(cur, o_suv, V3_HEADER_SIZE, "<f4", strands, 2,
                                       "strand texcoords", 152)
        present.append("strand_texcoord")
    ignored = [n for n, o in (("vertex_color", o_col), ("guide_hair", o_guide),
                              ("vertex_texcoord", o_vuv)) if o]
    meta = {
        "format": "TressFX",
        "tressfx": {"version": 3, "num_strands": strands, "vertices_per_strand": verts,
                    "follow_hairs_per_guide": follow, "both_ends_immovable": bool(both_ends),
                    "arrays": present, "ignored_arrays": ignored,
                    "immovable_vertices": int(immovable.sum())},
        "up_axis": "y",
        "units": "as stored",
        "file_frame": dict(CONVENTION),
    }
    return _groom(path, pos, strands, verts, None, None, {"immovable": immovable}, strand_attrs, meta)


def _groom(path, points, strands, verts, colors, transparency, point_attrs, strand_attrs, meta):
    try:
        return Groom(points, np.full(strands, verts, dtype=np.int32), colors=colors,
                     transparency=transparency, point_attributes=point_attrs,
                     strand_attributes=strand_attrs, metadata=meta)
    except GroomError as exc:
        raise FormatError(str(exc), path) from None


# ---------------------------------------------------------------------------- projects
def _numbers(tokens, path, lineno, n=None):
    try:
        values = [float(t.rstrip("fF")) for t in tokens]
    except ValueError:
        raise FormatError(f"line {lineno}: expected numbers, got {' '.join(tokens)!r}", path) from None
    if n is not None and len(values) != n:
        raise FormatError(f"line {lineno}: expected {n} numbers, got {len(values)}", path)
    if not all(math.isfinite(v) for v in values):
        raise FormatError(f"line {lineno}: numbers must be finite", path)
    return values


def parse_project(path) -> dict:
    """The parts and settings of a ``.tfxproj`` (paths as written, relative to the project)."""
    path = Path(path)
    data = read_file_bytes(path)
    if len(data) > MAX_PROJECT_BYTES:
        raise FormatError(f"a {len(data)}-byte project is too large for a .tfxproj", path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FormatError("not a text file (not UTF-8)", path, exc.start) from None
    project = {"version": None, "project_name": None, "parts": [], "meshes": [],
               "collision_spheres": [], "settings": {}}
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        tokens = line.split()
        key, rest = tokens[0], tokens[1:]
        low = key.lower()
        if low.endswith(".tfx"):
            if len(rest) < 4:
                raise FormatError(
                    f"line {lineno}: a hair part needs 'FILE.tfx followHairs radius tipSeparation "
                    f"SIMFILE [name]', got {line!r}", path)
            follow = _numbers(rest[:1], path, lineno)[0]
            radius, tip = _numbers(rest[1:3], path, lineno)
            if follow < 0 or follow != int(follow) or follow > 1024:
                raise FormatError(f"line {lineno}: follow hairs must be a whole number 0..1024", path)
            project["parts"].append({
                "file": key, "follow_hairs_per_guide": int(follow), "follow_radius": radius,
                "tip_separation": tip, "simulation_file": rest[3],
                "name": " ".join(rest[4:]) or Path(key).stem,
            })
            if len(project["parts"]) > MAX_PROJECT_PARTS:
                raise FormatError(f"more than {MAX_PROJECT_PARTS} hair parts", path)
        elif low == "version":
            project["version"] = " ".join(rest)
        elif low == "project_name":
            project["project_name"] = " ".join(rest)
        elif low == "collision_sphere":
            x, y, z, r = _numbers(rest, path, lineno, 4)
            if r < 0:
                raise FormatError(f"line {lineno}: a collision sphere radius is negative", path)
            project["collision_spheres"].append({"center": [x, y, z], "radius": r})
        elif not rest and "." in key:
            project["meshes"].append(key)
        elif rest:
            values = _numbers(rest, path, lineno)
            project["settings"][key] = values[0] if len(values) == 1 else values
        else:
            raise FormatError(f"line {lineno}: cannot read {line!r}", path)
    if not project["parts"]:
        raise FormatError("the project lists no .tfx hair parts", path)
    return project


def read_project(path) -> Groom:
    path = Path(path)
    project = parse_project(path)
    grooms = []
    parts = []
    total = 0
    for part in project["parts"]:   # every part's size first: nothing is read past the budget
        rel = Path(part["file"])
        if rel.is_absolute():
            raise FormatError(f"hair part {part['file']!r} must be a path relative to the project", path)
        part_path = path.parent / rel
        if not part_path.is_file():
            raise FormatError(f"hair part {part['file']!r} not found (looked for {part_path})", path)
        total += part_path.stat().st_size
        if total > MAX_PROJECT_TOTAL_BYTES:
            raise FormatError(f"the project's parts add up to more than {MAX_PROJECT_TOTAL_BYTES >> 20} MiB "
                              f"(at part {len(parts) + 1}, {part['file']!r}); refused", path)
        parts.append(part_path)
    for i, (part, part_path) in enumerate(zip(project["parts"], parts)):
        g = read_tfx(part_path)
        g = g.replace(strand_attributes={**g.strand_attributes,
                                         "part": np.full(g.num_strands, i, dtype=np.int32)})
        grooms.append(g)
    groom = Groom.concatenate(grooms)
    for part, g in zip(project["parts"], grooms):
        part["num_strands"] = g.num_strands
        part["vertices_per_strand"] = g.uniform_count
    groom.metadata = {"format": "TressFX project", "tressfx_project": project,
                      "up_axis": "y", "units": "as stored", "file_frame": dict(CONVENTION)}
    return groom


# ---------------------------------------------------------------------------- writing
TFX_POINTS = (4, 8, 16, 32, 64)


def nearest_tfx_points(count: float) -> int:
    """The TressFX vertex count (4, 8, 16, 32 or 64) nearest to ``count`` (ties go up)."""
    return min(TFX_POINTS, key=lambda n: (abs(n - count), -n))


def write(groom: Groom, path, points: int | None = None, declare: bool = True) -> None:
    """Write a TressFX 4 ``.tfx``.

    TressFX takes 4, 8, 16, 32 or 64 vertices per strand: strands are resampled (equal arc
    length) to ``points``, by default the count nearest the groom's median (a groom already at
    one of them is written as is). The groom's units (metres) and Y-up are declared in the
    header's reserved words (``declare=False`` leaves them zero)."""
    if points is None:
        n0 = groom.uniform_count
        points = n0 if n0 in TFX_POINTS else nearest_tfx_points(float(np.median(groom.counts)))
    if int(points) not in TFX_POINTS:
        raise UsageError(f"TressFX takes 4, 8, 16, 32 or 64 points per strand, not {points}")
    points = int(points)
    if groom.uniform_count != points:
        groom = groom.resampled(points)
    n = points
    S, P = groom.num_strands, groom.num_points
    immovable = groom.point_attributes.get("immovable")
    if immovable is None:
        immovable = np.zeros(P, dtype=bool)
        immovable[groom.offsets[:-1]] = True
    immovable = np.asarray(immovable).reshape(P, -1)[:, 0].astype(bool)
    blobs = []
    offset = V4_HEADER_SIZE

    def add(arr) -> int:
        nonlocal offset
        start = offset
        raw = np.ascontiguousarray(arr, dtype="<f4").tobytes()
        blobs.append(raw)
        offset += len(raw)
        return start

    pos = np.empty((P, 4), dtype=np.float32)
    pos[:, :3] = groom.points
    pos[:, 3] = np.where(immovable, 0.0, 1.0)
    o_pos = add(pos)
    o_suv = o_vuv = o_thick = o_col = 0
    suv = groom.strand_attributes.get("uv")
    if suv is not None and np.asarray(suv).shape == (S, 2) and np.asarray(suv).dtype.kind == "f":
        o_suv = add(suv)
    vuv = groom.point_attributes.get("uv")
    if vuv is not None and np.asarray(vuv).shape == (P, 2) and np.asarray(vuv).dtype.kind == "f":
        o_vuv = add(vuv)
    thick = groom.strand_attributes.get("thickness")
    if thick is not None and np.asarray(thick).shape == (S,) and np.asarray(thick).dtype.kind == "f":
        o_thick = add(thick)
    if groom.colors is not None or groom.transparency is not None:
        rgba = np.ones((P, 4), dtype=np.float32)
        if groom.colors is not None:
            rgba[:, :3] = groom.colors
        if groom.transparency is not None:
            rgba[:, 3] = 1.0 - groom.transparency
        o_col = add(rgba)
    marker = [int.from_bytes(w.ljust(4, b"\0"), "little") for w in (MARK, b"m", b"y")] if declare else []
    header = struct.pack("<f7I32I", 4.0, S, n, o_pos, o_suv, o_vuv, o_thick, o_col,
                         *(marker + [0] * (32 - len(marker))))
    assert len(header) == V4_HEADER_SIZE
    with atomic_write_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(header)
            for b in blobs:
                fh.write(b)
