"""A mesh's pixels on screen, for clearing only what was drawn (the renderer's HDR depth).

On the H200 a depth clear of the 1080p HDR target takes 0.12-0.14 ms a frame, the fill rate of
its few raster units, and only the head writes that depth with the compute rasteriser: clearing
the head's screen box of this frame and the last is the same frame for a third of the texels on
the target frame (docs/performance.md, "The HDR depth's clear"). The box is that of the head's
vertices (bound_points; a large mesh's occupied grid cells), the projected mesh's own extent:
in the bench's 100k-strand close-up the head's bounding box's corners project past the whole
frame, its vertices onto 54 % of it.
"""
from __future__ import annotations

import math

import numpy as np


FULL = "full"   # the whole target: a corner behind the eye, or nothing known of what is there


MAX_POINTS = 4096   # a mesh of more vertices is bounded by its occupied cells' corners
CELLS = 16          # the grid's cells a side over the mesh's box
_CORNER_STEPS = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.int64)


def bound_points(vertices) -> np.ndarray:
    """Points whose projections' box holds every vertex's in any view: the vertices where there
    are at most MAX_POINTS (the default head's 2,562), else the corners of the cells of a
    CELLS^3 grid over their box that hold a vertex (each vertex lies in its cell, a cell in the
    hull of its corners: at most a cell's size looser than the vertices, and O(vertices) once a
    head); of those, the corners of their convex hull (``hull_points``)."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    v = v[np.all(np.isfinite(v), axis=1)]
    if len(v) <= MAX_POINTS:
        return hull_points(v)
    lo, hi = v.min(axis=0), v.max(axis=0)
    pad = 1e-6 * (float(np.max(hi - lo)) + 1e-12)   # the corners' rounding, outward
    lo, hi = lo - pad, hi + pad
    size = (hi - lo) / CELLS
    cell = np.clip(((v - lo) / size).astype(np.int64), 0, CELLS - 1)
    n = CELLS + 1   # lattice points a side
    occupied = np.unique((cell[:, 0] * CELLS + cell[:, 1]) * CELLS + cell[:, 2])
    ijk = np.stack([occupied // (CELLS * CELLS), occupied // CELLS % CELLS, occupied % CELLS], axis=1)
    corners = (ijk[:, None, :] + _CORNER_STEPS[None]).reshape(-1, 3)
    ids = np.unique((corners[:, 0] * n + corners[:, 1]) * n + corners[:, 2])
    lattice = np.stack([ids // (n * n), ids // n % n, ids % n], axis=1)
    return hull_points(lo + lattice * size)


def hull_points(points: np.ndarray) -> np.ndarray:
    """The corners of the points' convex hull (all of them where the hull is flat or too few):
    a view that sees the points in front of its eye maps their hull to a convex shape whose
    extremes are corners' images, and a point behind the eye makes a corner so (its w is linear),
    so the screen box from the corners is the box from every point. The default head keeps 663
    of its 2,562 vertices: a moving camera's box a frame costs a quarter as much."""
    if len(points) <= 8:
        return points
    from scipy.spatial import ConvexHull, QhullError

    try:
        corners = ConvexHull(points).vertices
    except (QhullError, ValueError):   # flat, collinear or coincident: keep every point
        return points
    return np.ascontiguousarray(points[np.sort(corners)])


def screen_box(view_proj, points, model, size) -> tuple | str | None:
    """The pixels (x, y, width, height) that ``points`` (N, 3, model space, placed by the 4 x 4
    ``model``) cover on a ``size`` (width, height) target seen through ``view_proj``, one pixel
    wider each side for rounding; FULL where a point lies behind the eye (a body around the eye
    projects to no bounded box); None where it is off screen or there are no points."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    if len(pts) == 0:
        return None
    m = np.asarray(view_proj, np.float64) @ np.asarray(model, np.float64)
    clip = pts @ m[:, :3].T   # the points' homogeneous clip coordinates, no (N, 4) copy made
    clip += m[:, 3]
    cw = clip[:, 3]
    if not cw.min() > 1e-9 or not np.isfinite(clip).all():
        return FULL
    x, y = clip[:, 0] / cw, clip[:, 1] / cw
    w, h = int(size[0]), int(size[1])
    x0 = max(0, math.floor((float(x.min()) + 1.0) * 0.5 * w) - 1)
    y0 = max(0, math.floor((float(y.min()) + 1.0) * 0.5 * h) - 1)
    x1 = min(w, math.ceil((float(x.max()) + 1.0) * 0.5 * w) + 1)
    y1 = min(h, math.ceil((float(y.max()) + 1.0) * 0.5 * h) + 1)
    if x1 <= x0 or y1 <= y0:
        return None
    return (x0, y0, x1 - x0, y1 - y0)


def union(a, b) -> tuple | str | None:
    """The smallest box holding boxes ``a`` and ``b`` (each a box, FULL or None)."""
    if a == FULL or b == FULL:
        return FULL
    if a is None or b is None:
        return b if a is None else a
    x0, y0 = min(a[0], b[0]), min(a[1], b[1])
    x1, y1 = max(a[0] + a[2], b[0] + b[2]), max(a[1] + a[3], b[1] + b[3])
    return (x0, y0, x1 - x0, y1 - y0)
