"""Assembling a groom from the curves objects of a scene file (Alembic ``ICurves``, USD ``BasisCurves``).

The scene readers (:mod:`.alembic_curves`, :mod:`.usd_curves`) walk their files and hand each
curves object's points, vertex counts and widths through these checks, then concatenate the
objects, drop curves of fewer than 2 points and build the :class:`~mane.groom.Groom`.
"""
from __future__ import annotations

import numpy as np

from ..errors import FormatError, GroomError, UsageError
from ..groom import Groom


def check_time(time, what: str) -> float | None:
    """``time`` as a finite float (None stays None); ``what`` names its unit in the error."""
    if time is None:
        return None
    try:
        time = float(time)
    except (TypeError, ValueError):
        raise UsageError(f"time must be a number {what}, got {time!r}") from None
    if not np.isfinite(time):
        raise UsageError("time must be finite")
    return time


def check_counts(points: np.ndarray, counts: np.ndarray, where: str, path, mismatch: str) -> None:
    """FormatError unless the vertex counts are non-negative and add up to the points;
    ``mismatch`` is that error's text, with ``{total}`` and ``{points}``."""
    if counts.size and counts.min() < 0:
        raise FormatError(f"{where}: a curve has a negative vertex count", path)
    total = int(counts.sum())
    if total != len(points):
        raise FormatError(f"{where}: " + mismatch.format(total=total, points=len(points)), path)


def to_world(points: np.ndarray, widths: np.ndarray | None, world: np.ndarray):
    """(points, widths) through a 4x4 column-vector transform; widths scale by its mean scale."""
    points = points @ world[:3, :3].T + world[:3, 3]
    if widths is not None:
        widths = widths * abs(np.linalg.det(world[:3, :3])) ** (1.0 / 3.0)
    return points, widths


def concat(values: list):
    """The arrays concatenated, or None when any of them is None."""
    return None if any(v is None for v in values) else np.concatenate(values)


def object_index(counts_per_object: list) -> np.ndarray:
    """The strand attribute that says which object (0, 1, ...) each strand came from."""
    return np.repeat(np.arange(len(counts_per_object), dtype=np.int32), [len(c) for c in counts_per_object])


def drop_short_curves(counts: np.ndarray, path, per_point: dict, per_strand: dict):
    """Drop the curves of fewer than 2 points (FormatError when none is left).

    ``per_point`` / ``per_strand``: arrays (or None, or a dict of arrays) by name, one entry a
    point / a curve. Returns (counts, per_point, per_strand, the number dropped)."""
    keep = counts >= 2
    dropped = int((~keep).sum())
    if not keep.any():
        raise FormatError("every curve has fewer than 2 points: no hair", path)
    if dropped:
        pm = np.repeat(keep, counts)

        def mask(values: dict, m) -> dict:
            return {k: None if v is None else mask(v, m) if isinstance(v, dict) else v[m]
                    for k, v in values.items()}

        per_point, per_strand, counts = mask(per_point, pm), mask(per_strand, keep), counts[keep]
    return counts, per_point, per_strand, dropped


def build_groom(path, points: np.ndarray, counts: np.ndarray, **arrays) -> Groom:
    """The Groom (points, widths, colors and transparency as float32); a GroomError becomes a
    FormatError that names the file."""
    f32 = (lambda a: None if a is None else a.astype(np.float32))
    for key in ("widths", "colors", "transparency"):
        if key in arrays:
            arrays[key] = f32(arrays[key])
    try:
        return Groom(points.astype(np.float32), counts, **arrays)
    except GroomError as exc:
        raise FormatError(str(exc), path) from None
