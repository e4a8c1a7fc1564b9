"""A mesh's pixels on screen, for clearing only what was drawn (the renderer's HDR depth).

On the H200 a depth clear of the 1080p HDR target takes 0.12-0.14 ms a frame, the fill rate of
its few raster units, and only the head writes that depth with the compute rasteriser: clearing
the head's screen box of this frame and the last is the same frame for a third of the texels on
the target frame (docs/performance.md, "The HDR depth's clear"). The box is that of the head's
convex hull's vertices (hull_points), the projected mesh's own extent: in the bench's 100k-strand
close-up the head's bounding box's corners project past the whole frame, its hull onto 54 % of it.
"""
from __future__ import annotations

import math

import numpy as np


FULL = "full"   # the whole target: a corner behind the eye, or nothing known of what is there


def hull_points(vertices) -> np.ndarray:
    """The vertices of the convex hull of ``vertices`` (N, 3): the points whose projections
    bound every vertex's (a convex set's projection is the hull of its vertices'); all of them
    where the hull is degenerate (a flat or tiny mesh)."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    v = v[np.all(np.isfinite(v), axis=1)]
    if len(v) <= 8:
        return v
    try:
        from scipy.spatial import ConvexHull, QhullError

        return v[ConvexHull(v).vertices]
    except (QhullError, ValueError):   # coplanar or too few distinct points
        return v


def screen_box(view_proj, points, model, size) -> tuple | str | None:
    """The pixels (x, y, width, height) that ``points`` (N, 3, model space, placed by the 4 x 4
    ``model``) cover on a ``size`` (width, height) target seen through ``view_proj``, one pixel
    wider each side for rounding; FULL where a point lies behind the eye (a body around the eye
    projects to no bounded box); None where it is off screen or there are no points."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    if len(pts) == 0:
        return None
    clip = np.c_[pts, np.ones(len(pts))] @ (np.asarray(view_proj, np.float64) @ np.asarray(model, np.float64)).T
    if np.any(clip[:, 3] <= 1e-9) or not np.all(np.isfinite(clip)):
        return FULL
    ndc = clip[:, :2] / clip[:, 3:]
    w, h = int(size[0]), int(size[1])
    x0 = max(0, math.floor((ndc[:, 0].min() + 1.0) * 0.5 * w) - 1)
    y0 = max(0, math.floor((ndc[:, 1].min() + 1.0) * 0.5 * h) - 1)
    x1 = min(w, math.ceil((ndc[:, 0].max() + 1.0) * 0.5 * w) + 1)
    y1 = min(h, math.ceil((ndc[:, 1].max() + 1.0) * 0.5 * h) + 1)
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
