"""Coverage-driven strand LOD (issue 14): fewer, wider strands where many overlap a pixel.

Each frame, on the CPU and without reading anything back, the mean depth complexity of a groom
(or of each instance of it) is estimated from its box, its strand count and its strands' mean
length and width, as the camera sees them:

    D = N * l_px * max(w_px, m) / A_px

N rendered strands, l_px and w_px a strand's mean length and width in pixels at the depth of
the box's centre (seen side-on: no foreshortening), m the narrowest width the rasteriser draws
(pixels: a narrower strand is drawn that wide with its coverage as opacity), A_px the area of
the screen rectangle around the box's 8 projected corners (not clipped to the screen, so that
a close-up's D does not depend on how much of it is off-screen). When D exceeds
``settings.lod_depth`` only a fraction p = lod_depth / D of the strands is kept, every kept
strand widened by 1 / p: the expected coverage of a pixel (sum of widths x coverage) and the
deep opacity maps' additive opacity are the same, with p times fewer strands expanded and
scan-converted. A guide's strands are independent random offsets around it, so keeping the
first k of its ``strands_per_guide`` strands (k = round(p * strands_per_guide), at least 1;
the width scale is strands_per_guide / k exactly) is a uniform random subset spread over the
whole groom. A box wholly outside the view is culled (k = 0).

Segments too, where every visible instance is thinned: a strand whose projected length (at
the instance it looks longest in) would give segments shorter than SEGMENT_PX pixels is
expanded with fewer subdivisions of its guide segments (at least one: the guide's own points),
for every instance alike (the expanded strands share one point count); within that count a
thinned instance that looks smaller still uses fewer (``LodPlan.levels``).

    plan = lod_plan(view, size, boxes, strands_per_guide=16, guides=3125, mean_length=0.3,
                    mean_width=0.0004, min_width_px=0.5, lod_depth=64.0)
    plan.kept          # (instances,) strands kept per guide
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


SEGMENT_PX = 4.0
"""The shortest mean rendered segment (pixels) the segment LOD aims at: fewer subdivisions
when a strand's projected length over its segments falls below this."""


@dataclass(frozen=True)
class LodPlan:
    """Per instance: estimated depth complexity, keep fraction, strands kept per guide."""

    depth: tuple          # D per instance (inf: not estimated, the box reaches behind the eye)
    kept: tuple           # strands kept per guide per instance (0: culled)
    strands_per_guide: int
    length_px: tuple = ()  # a strand's mean projected length per instance (inf: not estimated)

    def subdivisions(self, full: int, guide_segments: int) -> int:
        """Subdivisions of a guide segment (at most ``full``) so that the longest-looking
        visible instance's segments are about SEGMENT_PX long; ``full`` without an estimate
        or while a visible instance keeps all its strands (the segment LOD acts only where
        the strands are thinned)."""
        visible = [(x, k) for x, k in zip(self.length_px, self.kept) if k > 0]
        if not visible or any(k >= self.strands_per_guide or not np.isfinite(x) for x, k in visible):
            return int(full)
        lengths = [x for x, _ in visible]
        return self._level(max(lengths), full, guide_segments)

    @staticmethod
    def _level(length_px: float, full: int, guide_segments: int) -> int:
        wanted = length_px / SEGMENT_PX
        return int(min(full, max(1, math.ceil(wanted / max(1, int(guide_segments))))))

    def levels(self, sub: int, guide_segments: int) -> tuple:
        """Per instance, the subdivisions (at most ``sub``, the buffer's) its strands use: fewer
        for a thinned instance whose strands look short (its other points sit at the guide
        segment's end: zero-length segments the rasterisers skip), ``sub`` for the rest."""
        out = []
        for x, k in zip(self.length_px or (float("inf"),) * len(self.kept), self.kept):
            thinned = 0 < k < self.strands_per_guide and np.isfinite(x)
            out.append(self._level(x, sub, guide_segments) if thinned else int(sub))
        return tuple(out)

    @property
    def width_scale(self) -> tuple:
        """Per instance: strands_per_guide / kept (1 for a culled instance)."""
        return tuple(self.strands_per_guide / k if k > 0 else 1.0 for k in self.kept)

    def keep_fraction(self) -> float:
        """Kept strands over all instances' strands."""
        return float(sum(self.kept)) / max(1, len(self.kept) * self.strands_per_guide)


def box_corners(lo, hi) -> np.ndarray:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def depth_complexity(view, size, corners, strands: int, mean_length: float, mean_width: float,
                     min_width_px: float, with_length: bool = False):
    """(D, visible) of strands filling the box with ``corners`` (8, 3) world points, seen by
    ``view`` (mane.render.passes.base.View) on a ``size`` (w, h) raster. D is inf when a corner
    is behind the eye (p = 1: no estimate); visible False when the box is wholly outside the
    view volume's sides. ``with_length``: (D, visible, l_px) with the projected mean length."""
    d, visible, l_px = _estimate(view, size, corners, strands, mean_length, mean_width, min_width_px)
    return (d, visible, l_px) if with_length else (d, visible)


def _estimate(view, size, corners, strands, mean_length, mean_width, min_width_px):
    w, h = float(size[0]), float(size[1])
    corners = np.asarray(corners, float)
    vp = np.asarray(view.view_proj, float)
    c = corners @ vp[:, :3].T
    c += vp[:, 3]
    center = corners.mean(axis=0)
    eye, fwd = view.eye, view.forward
    depth = sum((float(center[i]) - float(eye[i])) * float(fwd[i]) for i in range(3))
    cw = c[:, 3]
    if not cw.min() > 1e-6 or depth <= 1e-6:
        return float("inf"), True, float("inf")
    x, y = c[:, 0] / cw, c[:, 1] / cw
    x0, x1, y0, y1 = float(x.min()), float(x.max()), float(y.min()), float(y.max())
    if x1 < -1 or x0 > 1 or y1 < -1 or y0 > 1:
        return 0.0, False, 0.0
    area = (x1 - x0) * 0.5 * w * (y1 - y0) * 0.5 * h
    pixel = float(view.pixel_size) * (1.0 if view.ortho else depth)   # world size of a pixel there
    l_px = float(mean_length) / pixel
    w_px = max(float(mean_width) / pixel, float(min_width_px))
    return float(strands) * l_px * w_px / max(area, 1e-12), True, l_px


def kept_per_guide(strands_per_guide: int, depth: float, lod_depth: float) -> int:
    """Strands of a guide kept: all while D <= lod_depth (or lod_depth 0: off), else
    round(strands_per_guide * lod_depth / D), at least 1."""
    n = int(strands_per_guide)
    if not lod_depth > 0 or not depth > lod_depth or not np.isfinite(depth):
        return n
    return int(min(n, max(1, round(n * float(lod_depth) / depth))))


def lod_plan(view, size, boxes, *, strands_per_guide: int, guides: int, mean_length: float, mean_width: float,
             min_width_px: float, lod_depth: float) -> LodPlan:
    """The plan for instances with world boxes ``boxes`` ([(lo, hi), ...]), each ``guides`` x
    ``strands_per_guide`` strands."""
    depths, kept, lengths = [], [], []
    n = int(strands_per_guide) * int(guides)
    for lo, hi in boxes:
        d, visible, l_px = depth_complexity(view, size, box_corners(lo, hi), n, mean_length, mean_width,
                                            min_width_px, with_length=True)
        depths.append(d)
        lengths.append(l_px)
        kept.append(kept_per_guide(strands_per_guide, d, lod_depth) if visible else 0)
    return LodPlan(tuple(depths), tuple(kept), int(strands_per_guide), tuple(lengths))


def light_strand_step(view, size: int, box, strands: int, mean_length: float, mean_width: float,
                      lod_depth: float) -> int:
    """The deep opacity map's own LOD: every m-th expanded strand drawn into a ``size`` x ``size``
    light map (opacity x m), m = floor(D / lod_depth) with D the map's depth complexity
    (``depth_complexity`` in the light's ``view``, the strands at least a texel wide, as the
    compute scan conversion draws them); 1 (every strand) while D < 2 lod_depth, with lod_depth
    0, or without an estimate. The expanded strands' order holds no pattern that a stride would
    pick out (a guide's strands are independent offsets, its first k kept by the coverage LOD),
    so each strand is drawn with probability 1 / m at m times the opacity: the same expected
    opacity per texel and layer, m times fewer samples visited."""
    if not lod_depth > 0 or strands <= 0:
        return 1
    lo, hi = box
    d, visible = depth_complexity(view, (size, size), box_corners(lo, hi), strands, mean_length, mean_width, 1.0)
    if not visible or not np.isfinite(d):
        return 1
    return max(1, int(d // float(lod_depth)))


LENGTH_CHUNK = 2048
"""guides per block of ``mean_strand_length`` (its float64 temporaries stay in cache)."""


def mean_strand_length(points: np.ndarray) -> float:
    """Mean polyline length of (S, N, 3) guide points: each guide's length in float64, block by
    block (a guide's sum is its own, so the blocks change nothing), then their mean."""
    points = np.asarray(points)
    S = points.shape[0]
    if S == 0 or points.shape[1] < 2:
        return 0.0
    lengths = np.empty(S)
    for lo in range(0, S, LENGTH_CHUNK):
        p = np.asarray(points[lo:lo + LENGTH_CHUNK], np.float64)
        lengths[lo:lo + len(p)] = np.linalg.norm(np.diff(p, axis=1), axis=-1).sum(axis=1)
    return float(lengths.mean())


def mean_width(settings) -> float:
    """A rendered strand's mean width (m): root width tapering linearly to width_tip."""
    return float(settings.width) * 0.5 * (1.0 + float(settings.width_tip))
