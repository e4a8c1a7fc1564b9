"""cyHair ``.hair``: Cem Yuksel's binary hair format (his public hair models use it).

Little-endian. A 128-byte header::

    0   char     signature[4]     "HAIR"
    4   uint32   hair_count       strands
    8   uint32   point_count      points over all strands
    12  uint32   arrays           bit 0 segments, 1 points, 2 thickness, 3 transparency, 4 colors
    16  uint32   d_segments       segments per strand when there is no segments array
    20  float32  d_thickness      thickness when there is no thickness array
    24  float32  d_transparency   transparency when there is no transparency array
    28  float32  d_color[3]       colour when there is no colors array
    40  char     info[88]         free text

then only the arrays whose bit is set, in this order: segments ``uint16[hair_count]``,
points ``float32[point_count*3]``, thickness ``float32[point_count]``, transparency
``float32[point_count]``, colors ``float32[point_count*3]``. Without a segments array
every strand has ``d_segments`` segments and ``hair_count*(d_segments+1)`` must equal
``point_count``.

mane reads thickness as ``widths``, transparency and colors as themselves; a missing array
takes the header default for every point (``metadata['cyhair']['defaults_used']`` lists which).
The published models are Z-up: ``read(path, up="z")`` rotates the file's ``up`` axis to Y
(``up="y"`` keeps it as is; ``up=None``, what :func:`mane.load` uses, keeps the stored numbers
and records Z-up as the format's convention for :mod:`mane.io.units`) and
``write(groom, path, up="z")`` rotates back, so a round trip is exact. The format has no unit
(the models are in centimetre-like units): :mod:`mane.io.units` guesses it. mane writes
``mane units=m up=z`` at the start of the info text and reads it back as a declaration.
Strands of 0 segments (a single point) cannot be a mane strand: they are dropped and counted
in ``metadata['cyhair']['dropped_single_point_strands']``.
"""
from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np

from ..errors import FormatError, GroomError, UsageError
from ..groom import AXES, Groom
from .atomic import atomic_write_path
from .binary import Cursor, read_file_bytes

HEADER_SIZE = 128
SIGNATURE = b"HAIR"
BIT_SEGMENTS, BIT_POINTS, BIT_THICKNESS, BIT_TRANSPARENCY, BIT_COLORS = 1, 2, 4, 8, 16
_HEADER = struct.Struct("<4sIIII f f 3f 88s")
assert _HEADER.size == HEADER_SIZE

DEFAULT_THICKNESS = 1.0
DEFAULT_TRANSPARENCY = 0.0
DEFAULT_COLOR = (1.0, 1.0, 1.0)


def _check_up(up) -> str:
    if not isinstance(up, str) or up.lower() not in AXES:
        raise UsageError(f"up must be one of x, y, z; got {up!r}")
    return up.lower()


MARKER = re.compile(r"mane units=(m|cm|mm) up=([xyz])")


def read(path, up: str | None = "z") -> Groom:
    """Read a ``.hair`` file; ``up`` is the file's up axis, rotated to Y (None: kept as stored)."""
    raw = up is None
    up = "z" if raw else _check_up(up)
    path = Path(path)
    data = read_file_bytes(path)
    cur = Cursor(data, path)
    if len(data) < 4 or data[:4] != SIGNATURE:
        raise FormatError(f"not a cyHair file: the signature is {data[:4]!r}, expected b'HAIR'", path, 0)
    cur.need(HEADER_SIZE, "the 128-byte header")
    (_, hair_count, point_count, arrays, d_segments, d_thickness, d_transparency,
     c0, c1, c2, info_raw) = _HEADER.unpack_from(data, 0)
    cur.pos = HEADER_SIZE
    d_color = (c0, c1, c2)
    if arrays >> 5:
        raise FormatError(f"the arrays field has unknown bits set (0x{arrays:08x})", path, 12)
    if not arrays & BIT_POINTS:
        raise FormatError("the file has no points array (bit 1 of the arrays field is clear)", path, 12)
    if hair_count == 0 or point_count == 0:
        raise FormatError(f"the file holds no hair ({hair_count} strands, {point_count} points)", path, 4)
    for name, value, off in (("d_thickness", d_thickness, 20), ("d_transparency", d_transparency, 24)):
        if not np.isfinite(value):
            raise FormatError(f"{name} is not finite ({value})", path, off)
    if not np.all(np.isfinite(d_color)):
        raise FormatError(f"d_color is not finite ({d_color})", path, 28)
    # The expected size from the header, compared with the file before anything is allocated.
    per_point = 12 + 4 * bool(arrays & BIT_THICKNESS) + 4 * bool(arrays & BIT_TRANSPARENCY) \
        + 12 * bool(arrays & BIT_COLORS)
    expected = HEADER_SIZE + 2 * hair_count * bool(arrays & BIT_SEGMENTS) + per_point * point_count
    if expected != len(data):
        what = "truncated" if expected > len(data) else "has trailing bytes"
        raise FormatError(
            f"{what}: the header declares {hair_count} strands and {point_count} points "
            f"(arrays 0x{arrays:02x}), which take {expected} bytes, but the file has {len(data)}",
            path, min(expected, len(data)))

    if arrays & BIT_SEGMENTS:
        segments = cur.array("<u2", hair_count, "segments array").astype(np.int64)
        total = int(segments.sum()) + hair_count
        if total != point_count:
            raise FormatError(
                f"the segments array adds up to {total} points but the header says {point_count}",
                path, HEADER_SIZE)
        counts = segments + 1
    else:
        if hair_count * (d_segments + 1) != point_count:
            raise FormatError(
                f"without a segments array every strand has d_segments={d_segments} segments, "
                f"so {hair_count} strands need {hair_count * (d_segments + 1)} points, "
                f"but the header says {point_count}", path, 16)
        counts = np.full(hair_count, d_segments + 1, dtype=np.int64)
    pts_off = cur.pos
    points = cur.array("<f4", point_count * 3, "points array", finite=True).reshape(-1, 3)

    defaults_used = []

    def per_point_array(bit, name, n, default):
        if arrays & bit:
            return cur.array("<f4", point_count * n, f"{name} array", finite=True).reshape(
                (-1, n) if n > 1 else (-1,))
        defaults_used.append(name)
        shape = (point_count, n) if n > 1 else (point_count,)
        return np.broadcast_to(np.asarray(default, dtype=np.float32), shape)

    widths = per_point_array(BIT_THICKNESS, "thickness", 1, d_thickness)
    transparency = per_point_array(BIT_TRANSPARENCY, "transparency", 1, d_transparency)
    colors = per_point_array(BIT_COLORS, "colors", 3, d_color)
    assert cur.pos == len(data)

    dropped = int((counts < 2).sum())
    keep_points = None
    if dropped:
        if dropped == hair_count:
            raise FormatError("every strand has a single point (0 segments): no hair", path, HEADER_SIZE)
        keep_points = np.repeat(counts >= 2, counts)
        counts = counts[counts >= 2]
        points, widths, transparency, colors = (
            a[keep_points] for a in (points, widths, transparency, colors))

    info = info_raw.split(b"\0", 1)[0].decode("utf-8", "replace")
    mark = MARKER.match(info)
    if mark:
        frame = {"units": mark.group(1), "units_source": "declared", "up": mark.group(2),
                 "up_source": "declared"}
        info = info[mark.end():].lstrip(" ;")
    else:
        frame = {"units": None, "units_source": None, "up": "z", "up_source": "convention"}
    meta = {
        "format": "cyHair",
        "cyhair": {
            "info": info,
            "arrays": [n for b, n in ((BIT_SEGMENTS, "segments"), (BIT_POINTS, "points"),
                                      (BIT_THICKNESS, "thickness"), (BIT_TRANSPARENCY, "transparency"),
                                      (BIT_COLORS, "colors")) if arrays & b],
            "defaults": {"segments": int(d_segments), "thickness": float(d_thickness),
                         "transparency": float(d_transparency), "color": [float(c) for c in d_color]},
            "defaults_used": defaults_used,
            "up_axis": frame["up"] if raw else up,
            "dropped_single_point_strands": dropped,
        },
        "up_axis": frame["up"] if raw else "y",
        "units": "as stored in the file (cyHair models use arbitrary units)",
    }
    if raw:
        meta["file_frame"] = frame
    try:
        groom = Groom(points, counts, widths=widths, colors=colors, transparency=transparency,
                      metadata=meta)
    except GroomError as exc:
        raise FormatError(str(exc), path, pts_off) from None
    return groom.with_up_axis(up, "y") if (up != "y" and not raw) else groom


def write(groom: Groom, path, up: str = "z", info: str | None = None, compact: bool = True,
          declare: bool = True) -> None:
    """Write ``groom`` as cyHair; ``up`` is the file's up axis (Y is rotated to it).

    With ``compact`` an array whose value is the same at every point goes in the header's
    default instead (and the segments array is left out when every strand has the same count).
    Strands of more than 65,536 points do not fit the format's uint16 segment counts.
    """
    up = _check_up(up)
    g = groom.with_up_axis("y", up) if up != "y" else groom
    counts = g.counts.astype(np.int64)
    if counts.max() - 1 > 0xFFFF and not (compact and g.uniform_count is not None):
        raise GroomError(f"a strand has {int(counts.max())} points; cyHair allows at most 65,536")
    P, S = g.num_points, g.num_strands
    if info is None:
        info = str(groom.metadata.get("cyhair", {}).get("info", "")) if isinstance(
            groom.metadata.get("cyhair"), dict) else ""
    if declare:  # the groom is in metres (mane's unit); say so, and which axis is up in the file
        info = f"mane units=m up={up}" + (f"; {info}" if info else "")
    info_bytes = info.encode("utf-8")[:87]

    arrays = BIT_POINTS
    d_segments = 0
    if compact and g.uniform_count is not None:
        d_segments = g.uniform_count - 1
    else:
        arrays |= BIT_SEGMENTS
    blobs = []
    if arrays & BIT_SEGMENTS:
        blobs.append((counts - 1).astype("<u2").tobytes())
    blobs.append(g.points.astype("<f4").tobytes())

    def optional(bit, values, default, n):
        nonlocal arrays
        if values is None:
            return default
        v = np.asarray(values, dtype=np.float32).reshape(P, n)
        if compact and np.all(v == v[0]):
            return tuple(float(x) for x in v[0]) if n > 1 else float(v[0, 0])
        arrays |= bit
        blobs.append(v.astype("<f4").tobytes())
        return default

    d_thickness = optional(BIT_THICKNESS, g.widths, DEFAULT_THICKNESS, 1)
    d_transparency = optional(BIT_TRANSPARENCY, g.transparency, DEFAULT_TRANSPARENCY, 1)
    d_color = optional(BIT_COLORS, g.colors, DEFAULT_COLOR, 3)
    header = _HEADER.pack(SIGNATURE, S, P, arrays, d_segments, d_thickness, d_transparency,
                          *d_color, info_bytes.ljust(88, b"\0"))
    with atomic_write_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(header)
            for blob in blobs:
                fh.write(blob)
