"""USC-HairSalon ``.data`` (also Hair20k and several strand-reconstruction projects).

Little-endian::

    int32 n_strands
    n_strands times:  int32 n_vertices, then n_vertices * float32[3]

The USC database has 343 hairstyles of 10,000 strand *slots*, one per scalp root; a slot
with a single vertex (or none) means "no hair at this root". Y is up; the unit is about
0.82 m, kept as stored (``mane convert --scale 0.82`` gives metres).

Empty slots: a mane strand needs at least 2 points, so slots of 0 or 1 vertex are left out
of the groom but not forgotten. Every strand gets the strand attribute ``root_index``
(int32, the index of its slot in the file) and ``metadata['usc_hairsalon']`` records
``num_slots``, and for the empty slots their ``index``, ``vertices`` (0 or 1) and the
``points`` of the 1-vertex ones. :func:`write` puts the empty slots back where they were
when that information is present and consistent with the groom, so read -> write gives
back the same bytes. (The CT2Hair ``.bin`` variant frames strands the same way with
7 float32 per point: ``read(path, floats_per_point=7)`` keeps the first three; ``mane.load``
reads ``.bin`` files that way. CT2Hair's data are X-up by convention.)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError, GroomError
from ..groom import Groom
from .atomic import atomic_write_path
from .binary import Cursor, check_count, read_file_bytes


def read(path, floats_per_point: int = 3) -> Groom:
    path = Path(path)
    if floats_per_point not in (3, 7):
        raise FormatError(f"floats_per_point must be 3 or 7, got {floats_per_point!r}", path)
    data = read_file_bytes(path)
    cur = Cursor(data, path)
    n_slots = cur.i32("the strand count")
    if n_slots == 0:
        raise FormatError("the file holds no strands (n_strands is 0)", path, 0)
    check_count(n_slots, "n_strands", path, (len(data) - 4) // 4, 0)
    stride = 4 * floats_per_point
    counts = np.empty(n_slots, dtype=np.int64)
    starts = np.empty(n_slots, dtype=np.int64)
    pos = 4
    size = len(data)
    # Walk the framing first (ints only), checking every count against the bytes left.
    ints = memoryview(data)
    for i in range(n_slots):
        if pos + 4 > size:
            raise FormatError(f"truncated: strand {i} of {n_slots} has no vertex count", path, pos)
        n = int.from_bytes(ints[pos:pos + 4], "little", signed=True)
        if n < 0:
            raise FormatError(f"strand {i} has a negative vertex count ({n})", path, pos)
        if n > (size - pos - 4) // stride:
            raise FormatError(
                f"truncated: strand {i} declares {n} vertices ({n * stride} bytes) but only "
                f"{size - pos - 4} bytes are left", path, pos)
        counts[i] = n
        starts[i] = pos + 4
        pos += 4 + n * stride
    if pos != size:
        raise FormatError(f"{size - pos} unexpected bytes after the last strand", path, pos)

    total = int(counts.sum())
    # Gather every vertex at once: byte offsets of each vertex's first float.
    first = np.repeat(starts, counts) + stride * (
        np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(counts) - counts, counts))
    flat = np.frombuffer(data, dtype="<f4")  # the file is 4-byte framed throughout
    idx = (first // 4)[:, None] + np.arange(3)
    values = flat[idx] if total else np.zeros((0, 3), np.float32)
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(np.argmax(bad.any(axis=1)))
        col = int(np.argmax(bad[row]))
        raise FormatError(f"vertex coordinate is not finite ({values[row, col]})", path,
                          int(first[row]) + 4 * col)
    hair = counts >= 2
    if not hair.any():
        raise FormatError(f"all {n_slots} strand slots are empty (0 or 1 vertex): no hair", path, 0)
    keep = np.repeat(hair, counts)
    empty = np.flatnonzero(~hair)
    single = np.repeat(counts == 1, counts)
    meta = {
        "format": "USC-HairSalon",
        "usc_hairsalon": {
            "num_slots": int(n_slots),
            "num_empty_slots": int(len(empty)),
            "empty_slots": {
                "index": empty.tolist(),
                "vertices": counts[empty].astype(int).tolist(),
                "points": values[single].astype(float).tolist(),
            },
            "floats_per_point": floats_per_point,
        },
        # USC-HairSalon is Y-up (its unit is about 0.82 m: guessed as metres); CT2Hair is X-up
        "file_frame": {"units": None, "units_source": None, "up": "y" if floats_per_point == 3 else "x",
                       "up_source": "convention"},
        "up_axis": "y",
        "units": "as stored (USC-HairSalon unit is about 0.82 m)",
    }
    try:
        return Groom(values[keep], counts[hair],
                     strand_attributes={"root_index": np.flatnonzero(hair).astype(np.int32)},
                     metadata=meta)
    except GroomError as exc:
        raise FormatError(str(exc), path) from None


def _empty_slots(groom: Groom):
    """(num_slots, root_index, empty index, empty vertex counts, empty points) or None."""
    meta = groom.metadata.get("usc_hairsalon")
    roots = groom.strand_attributes.get("root_index")
    if not isinstance(meta, dict) or roots is None:
        return None
    try:
        n_slots = int(meta["num_slots"])
        slots = meta["empty_slots"]
        index = np.asarray(slots["index"], dtype=np.int64).reshape(-1)
        nverts = np.asarray(slots["vertices"], dtype=np.int64).reshape(-1)
        points = np.asarray(slots["points"], dtype=np.float32).reshape(-1, 3)
        roots = np.asarray(roots, dtype=np.int64).reshape(-1)
    except (KeyError, TypeError, ValueError):
        return None
    if (len(index) != len(nverts) or not np.isin(nverts, (0, 1)).all()
            or int(nverts.sum()) != len(points) or len(index) + len(roots) != n_slots):
        return None
    occupied = np.zeros(n_slots, dtype=bool)
    all_idx = np.concatenate([index, roots])
    if all_idx.size and (all_idx.min() < 0 or all_idx.max() >= n_slots):
        return None
    occupied[all_idx] = True
    if not occupied.all():
        return None
    return n_slots, roots, index, nverts, points


def write(groom: Groom, path, restore_empty: bool = True) -> None:
    """Write the groom; empty slots recorded by :func:`read` go back in their places."""
    slots = _empty_slots(groom) if restore_empty else None
    pts = groom.points.astype("<f4")
    counts = groom.counts.astype(np.int64)
    if slots is None:
        pieces = [("strand", s) for s in range(groom.num_strands)]
    else:
        n_slots, roots, index, nverts, points = slots
        pieces = [None] * n_slots
        for s, r in enumerate(roots):
            pieces[r] = ("strand", s)
        single_pos = np.cumsum(nverts) - nverts
        for k, (i, nv) in enumerate(zip(index, nverts)):
            pieces[i] = ("empty", int(nv), int(single_pos[k]))
    offsets = groom.offsets
    chunks = [np.array([len(pieces)], dtype="<i4").tobytes()]
    for piece in pieces:
        if piece[0] == "strand":
            s = piece[1]
            chunks.append(np.array([counts[s]], dtype="<i4").tobytes())
            chunks.append(pts[offsets[s]:offsets[s + 1]].tobytes())
        else:
            _, nv, at = piece
            chunks.append(np.array([nv], dtype="<i4").tobytes())
            if nv:
                chunks.append(points[at:at + 1].astype("<f4").tobytes())
    with atomic_write_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(b"".join(chunks))
