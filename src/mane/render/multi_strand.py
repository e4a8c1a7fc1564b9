"""Multi-strand interpolation (Woodhouse §4.3.1): every rendered strand blends 3 guide curves
with barycentric weights, plus a root offset; the hybrid flags the strands whose guides
straddle a collider so that they take the single-strand form (the Vulkan hair's failure case).

    table = StrandTable.from_guide_weights(ctx, gw)                    # grooming's GuideWeights
    table = StrandTable.procedural(ctx, roots, strands_per_guide=16)   # hashed barycentrics
    table.set_hybrid_flags(positions, sdf, margin)                     # per-strand fallback flag

GPU layout (std430, binding 2): per strand ``ivec4 guides`` (w: flags, bit 0 = single-strand
fallback), ``vec4 weights`` (the heaviest guide first), ``vec4 offset`` (xyz metres, world).
"""
from __future__ import annotations

import numpy as np

from ..errors import UsageError
from . import strand_math as sm

RECORD_BYTES = 48
FLAG_SINGLE = 1
INDEX_NAMES = ("guide_indices", "indices", "guides", "triangles", "guide_ids")
WEIGHT_NAMES = ("weights", "barycentric", "barycentrics", "bary")
OFFSET_NAMES = ("offsets", "root_offsets", "offset")


def _attr(obj, names):
    for n in names:
        if isinstance(obj, dict) and n in obj:
            return obj[n]
        if not isinstance(obj, dict) and hasattr(obj, n):
            return getattr(obj, n)
    return None


def unpack_guide_weights(gw, weights=None, offsets=None):
    """(indices (R, 3) int, weights (R, 3) float, offsets (R, 3) float) from a GuideWeights
    (duck-typed: guide_indices/indices/guides, weights, offsets), a dict or arrays."""
    if weights is None and not isinstance(gw, np.ndarray) and not isinstance(gw, (list, tuple)):
        idx, w, off = _attr(gw, INDEX_NAMES), _attr(gw, WEIGHT_NAMES), _attr(gw, OFFSET_NAMES)
    elif weights is None and isinstance(gw, (list, tuple)) and len(gw) in (2, 3):
        idx, w, off = gw[0], gw[1], gw[2] if len(gw) == 3 else None
    else:
        idx, w, off = gw, weights, offsets
    if idx is None or w is None:
        raise UsageError("guide weights need (R, 3) guide indices and (R, 3) barycentric weights")
    idx = np.asarray(idx, dtype=np.int64).reshape(-1, 3)
    w = np.asarray(w, dtype=np.float64).reshape(-1, 3)
    if len(idx) != len(w):
        raise UsageError(f"{len(idx)} guide index triples but {len(w)} weight triples")
    off = np.zeros((len(idx), 3)) if off is None else np.asarray(off, dtype=np.float64).reshape(-1, 3)
    if len(off) != len(idx):
        raise UsageError(f"{len(idx)} strands but {len(off)} root offsets")
    return idx, w, off


def nearest_triangles(roots: np.ndarray) -> np.ndarray:
    """(S, 3): each guide with its two nearest guides (by root)."""
    roots = np.asarray(roots, dtype=np.float64)
    S = len(roots)
    if S < 3:
        return np.array([[g, (g + 1) % S, (g + 2) % S] for g in range(S)], dtype=np.int64)
    from scipy.spatial import cKDTree

    _, nn = cKDTree(roots).query(roots, k=3)
    nn = np.asarray(nn, dtype=np.int64)
    nn[:, 0] = np.arange(S)        # ties at distance 0: the guide itself first
    return nn


def procedural_weights(num_guides: int, strands_per_guide: int, triangles: np.ndarray,
                       keep_guide: bool = True):
    """Woodhouse: per guide g, strands_per_guide strands at random barycentrics of the triangle
    (g, n1, n2), seeded by guide and strand (stable frame to frame); strand 0 is the guide."""
    g = np.repeat(np.arange(num_guides), strands_per_guide)
    j = np.tile(np.arange(strands_per_guide), num_guides)
    seed = sm.strand_seed(g, j) ^ np.uint32(0xB5297A4D)
    a, b = sm._rand_stream(seed, 2)
    w = sm.random_barycentrics(a, b)
    if keep_guide:
        w[j == 0] = (1.0, 0.0, 0.0)
    return np.asarray(triangles, dtype=np.int64)[g], w


def ellipsoid_sdf(colliders):
    """An approximate signed distance (exact zero set) to the union of ellipsoids."""
    cols = np.asarray(colliders, dtype=np.float64).reshape(-1, 6)

    def sdf(p):
        p = np.asarray(p, dtype=np.float64)
        out = np.full(p.shape[:-1], np.inf)
        for c in cols:
            q = (p - c[:3]) / c[3:]
            k0 = np.linalg.norm(q, axis=-1)
            k1 = np.linalg.norm(q / c[3:], axis=-1)
            out = np.minimum(out, k0 * (k0 - 1.0) / np.maximum(k1, 1e-12))
        return out

    return sdf


def straddle_flags(positions, indices, weights, sdf, margin: float = 0.002, samples: int = 7) -> np.ndarray:
    """(R,) bool: the straight segment between two of a strand's (weighted) guides' points,
    at any point index along them, passes deeper than ``margin`` inside the collider."""
    P = np.asarray(positions, dtype=np.float64)           # (S, N, 3)
    idx = np.asarray(indices, dtype=np.int64)
    active = np.asarray(weights) > 1e-6
    key = np.where(active, idx, -1)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    t = (np.arange(samples) + 1.0) / (samples + 1.0)
    flags_u = np.zeros(len(uniq), bool)
    edges = []
    for u, tri in enumerate(uniq):
        live = [int(x) for x in tri if x >= 0]
        for a in range(len(live)):
            for b in range(a + 1, len(live)):
                if live[a] != live[b]:
                    edges.append((u, live[a], live[b]))
    if edges:
        e = np.asarray(edges)
        pa, pb = P[e[:, 1]], P[e[:, 2]]                       # (E, N, 3)
        pts = pa[:, :, None] * (1 - t)[:, None] + pb[:, :, None] * t[:, None]   # (E, N, T, 3)
        d = sdf(pts.reshape(-1, 3)).reshape(len(e), -1)
        inside = (d < -float(margin)).any(axis=1)
        np.logical_or.at(flags_u, e[:, 0], inside)
    return flags_u[np.asarray(inverse).reshape(-1)]


class StrandTable:
    """The rendered strands' records on the GPU (multi / hybrid interpolation)."""

    def __init__(self, ctx, indices, weights, offsets=None, num_guides: int | None = None):
        idx, w, off = unpack_guide_weights(indices, weights, offsets)
        if num_guides is not None and (idx.min() < 0 or idx.max() >= num_guides):
            raise UsageError(f"guide indices must lie in 0..{num_guides - 1}")
        if len(idx) == 0:
            raise UsageError("no rendered strands in the guide weights")
        s = w.sum(axis=1, keepdims=True)
        w = np.where(np.abs(s) > 1e-12, w / np.where(np.abs(s) > 1e-12, s, 1.0), w)
        order = np.argsort(-w, axis=1, kind="stable")         # heaviest guide first
        self.indices = np.take_along_axis(idx, order, axis=1)
        self.weights = np.take_along_axis(w, order, axis=1)
        self.offsets = off
        self.flags = np.zeros(len(idx), np.int32)
        self.ctx = ctx
        self.buffer = None
        self.upload()

    @classmethod
    def procedural(cls, ctx, roots, strands_per_guide: int, keep_guide: bool = True, triangles=None):
        roots = np.asarray(roots, dtype=np.float64)
        tri = nearest_triangles(roots) if triangles is None else np.asarray(triangles, dtype=np.int64)
        idx, w = procedural_weights(len(roots), int(strands_per_guide), tri, keep_guide)
        return cls(ctx, idx, w, None, num_guides=len(roots))

    @classmethod
    def from_guide_weights(cls, ctx, gw, num_guides: int | None = None, weights=None, offsets=None):
        idx, w, off = unpack_guide_weights(gw, weights, offsets)
        return cls(ctx, idx, w, off, num_guides=num_guides)

    @property
    def count(self) -> int:
        return len(self.indices)

    def records(self) -> np.ndarray:
        rec = np.zeros((self.count, 12), np.float32)
        ints = rec.view(np.int32)
        ints[:, 0:3] = self.indices
        ints[:, 3] = self.flags
        rec[:, 4:7] = self.weights
        rec[:, 8:11] = self.offsets
        return rec

    def upload(self) -> None:
        data = self.records().tobytes()
        if self.buffer is not None and self.buffer.size == len(data):
            self.buffer.write(data)
        else:
            if self.buffer is not None:
                self.buffer.release()
            self.buffer = self.ctx.buffer(data)

    def set_hybrid_flags(self, positions, sdf, margin: float = 0.002) -> np.ndarray:
        f = straddle_flags(positions, self.indices, self.weights, sdf, margin)
        self.flags = np.where(f, FLAG_SINGLE, 0).astype(np.int32)
        self.upload()
        return f

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
            self.buffer = None
