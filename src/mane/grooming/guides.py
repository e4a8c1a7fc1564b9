"""Guides for dense grooms: choosing K guide strands, and how every strand follows them.

Selection (deterministic by seed):

- ``fps``: farthest-point sampling on the roots, for an even spread of guides over the scalp.
- ``kmeans``: k-means over roots plus shape features (points along the strand relative to
  its root), each guide being the member strand nearest its cluster's centre, so guides
  also follow the groom's partings and clumps.

Interpolation data, per render strand (``GuideWeights``, arrays ready for GPU upload):

- single-strand: the nearest guide, and the root's offset from that guide's root in the
  guide's root frame (tangent, bitangent, normal);
- multi-strand: 3 guides and barycentric weights. Among the triangles made from the 6 nearest
  guide roots, the smallest one that contains the root's projection and faces along the root
  normal is used; where none does (the edge of the scalp) the 3 nearest guides get clamped
  barycentric weights (negatives set to zero, renormalised to sum to 1). A small root offset,
  in the frame of the heaviest guide, puts the interpolated root back on the surface.

``reconstruct`` is the NumPy twin of the interpolation shader: along the strand the guide's
root frame is carried by the smallest rotation from the guide's root direction to its local
direction, so offsets follow curls and droop without a sequential pass.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..errors import GroomError, UsageError
from ..groom import Groom
from .follicles import frame_from_normal


@dataclass(frozen=True, eq=False)
class GuideWeights:
    """How S render strands follow K guides.

    guides: (K,) int64 strand indices (in the source groom) of the guides.
    indices: (S, 3) int32 guide numbers (0..K-1) for multi-strand interpolation, heaviest first.
    weights: (S, 3) float32 barycentric weights, each row summing to 1.
    inside: (S,) bool, True where the root's projection lies in its guide triangle.
    guide: (S,) int32 nearest guide number, for single-strand interpolation.
    offset: (S, 3) float32 root offset from that guide's root in its root frame (t, b, n), m.
    multi_offset: (S, 3) float32 root correction for multi-strand interpolation, in the root
    frame of guide ``indices[:, 0]``, m.
    guide_frames: (K, 3, 3) float32 root frames of the guides, rows (tangent, bitangent, normal).
    """

    guides: np.ndarray
    indices: np.ndarray
    weights: np.ndarray
    inside: np.ndarray
    guide: np.ndarray
    offset: np.ndarray
    multi_offset: np.ndarray
    guide_frames: np.ndarray

    @property
    def root_offsets(self) -> np.ndarray:
        """(S, 3) float32 world-space multi-strand root correction at rest (for a renderer that
        adds a fixed world offset to the blend of its 3 guides)."""
        f = self.guide_frames[self.indices[:, 0].astype(np.int64)].astype(np.float64)
        return np.einsum("si,sij->sj", self.multi_offset.astype(np.float64), f).astype(np.float32)

    @property
    def num_guides(self) -> int:
        return len(self.guides)

    @property
    def num_strands(self) -> int:
        return len(self.guide)


# ---------------------------------------------------------------------------- frames


def root_frames(groom: Groom) -> np.ndarray:
    """(S, 3, 3) root frames, rows (tangent, bitangent, normal).

    From the strand attributes ``root_normal`` and ``root_tangent`` when present (grown
    grooms carry them), else the normal is the first segment's direction and the tangent
    comes from ``frame_from_normal``.
    """
    attrs = groom.strand_attributes
    if "root_normal" in attrs:
        n = np.asarray(attrs["root_normal"], dtype=np.float64)
    else:
        off = groom.offsets[:-1]
        n = groom.points[off + 1].astype(np.float64) - groom.points[off]
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    if "root_tangent" in attrs:
        t = np.asarray(attrs["root_tangent"], dtype=np.float64)
        t = t - (t * n).sum(axis=1, keepdims=True) * n
        t = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
    else:
        t, _ = frame_from_normal(n)
    b = np.cross(n, t)
    return np.stack([t, b, n], axis=1)


# ---------------------------------------------------------------------------- selection


def _check_k(groom: Groom, k: int) -> int:
    k = int(k)
    if k <= 0:
        raise UsageError(f"the number of guides must be positive, got {k}")
    if k > groom.num_strands:
        raise UsageError(f"cannot choose {k} guides from {groom.num_strands} strands; "
                         f"ask for at most {groom.num_strands}")
    return k


def farthest_point_guides(roots: np.ndarray, k: int, seed: int = 0,
                          chosen: np.ndarray | None = None) -> np.ndarray:
    """(k,) indices of roots chosen by farthest-point sampling (starting at a seeded one).

    ``chosen`` indices are kept first and the rest added farthest from them.
    """
    roots = np.asarray(roots, dtype=np.float64)
    S = len(roots)
    out = [] if chosen is None else [int(i) for i in chosen]
    dist = np.full(S, np.inf)
    for i in out:
        dist = np.minimum(dist, np.linalg.norm(roots - roots[i], axis=1))
    if not out:
        first = int(np.random.default_rng(seed).integers(S))
        out.append(first)
        dist = np.linalg.norm(roots - roots[first], axis=1)
    while len(out) < k:
        nxt = int(np.argmax(dist))
        if dist[nxt] <= 0 and np.isfinite(dist[nxt]):  # coincident roots: any unused strand
            unused = np.setdiff1d(np.arange(S), out)
            nxt = int(unused[0])
        out.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(roots - roots[nxt], axis=1))
        dist[nxt] = -1.0
    return np.asarray(out[:k], dtype=np.int64)


def _shape_features(groom: Groom, samples: int = 4) -> np.ndarray:
    g = groom if groom.uniform_count == samples + 1 else groom.resampled(samples + 1)
    p = g.as_padded().astype(np.float64)
    return (p[:, 1:] - p[:, :1]).reshape(len(p), -1)


def select_guides(groom: Groom, k: int, method: str = "fps", seed: int = 0,
                  shape_weight: float = 0.5) -> np.ndarray:
    """(k,) distinct strand indices of guides, by ``'fps'`` or ``'kmeans'``.

    shape_weight: for k-means, how much strand shape counts against root position (the shape
    features are points along the strand relative to its root, in metres).
    """
    k = _check_k(groom, k)
    roots = groom.roots.astype(np.float64)
    if method == "fps":
        return farthest_point_guides(roots, k, seed)
    if method != "kmeans":
        raise UsageError(f"unknown guide selection {method!r}; use 'fps' or 'kmeans'")
    from scipy.cluster.vq import kmeans2
    from scipy.spatial import cKDTree

    feats = np.concatenate([roots, shape_weight * _shape_features(groom)], axis=1)
    scale = feats.std(axis=0).mean() or 1.0
    feats = feats / scale
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "one of the clusters is empty": handled below
        centroids, labels = kmeans2(feats, k, iter=20, minit="++", seed=seed)
    # the member nearest each non-empty cluster's centroid
    d = np.linalg.norm(feats - centroids[labels], axis=1)
    order = np.lexsort((d, labels))
    first = np.ones(len(order), dtype=bool)
    first[1:] = labels[order][1:] != labels[order][:-1]
    picked = order[first]
    if len(picked) < k:  # empty clusters: the strands nearest their centroids, then FPS
        used = set(picked.tolist())
        for c in np.setdiff1d(np.arange(k), labels[picked]):
            _, near = cKDTree(feats).query(centroids[c], k=min(len(feats), 16))
            for j in np.atleast_1d(near):
                if int(j) not in used:
                    used.add(int(j))
                    picked = np.append(picked, j)
                    break
        if len(picked) < k:
            picked = farthest_point_guides(roots, k, seed, chosen=picked)
    return np.asarray(picked[:k], dtype=np.int64)


# ---------------------------------------------------------------------------- weights


def _barycentric(p, a, b, c):
    """Barycentrics of p's projection onto triangles (a, b, c), and a degeneracy flag."""
    v0, v1, v2 = b - a, c - a, p - a
    d00 = (v0 * v0).sum(-1)
    d01 = (v0 * v1).sum(-1)
    d11 = (v1 * v1).sum(-1)
    d20 = (v2 * v0).sum(-1)
    d21 = (v2 * v1).sum(-1)
    den = d00 * d11 - d01 * d01
    ok = den > 1e-6 * d00 * d11
    den = np.where(ok, den, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.stack([1.0 - v - w, v, w], axis=-1), ok


def compute_guide_weights(groom: Groom, guides, candidates: int = 6) -> GuideWeights:
    """Single- and multi-strand interpolation data for every strand of ``groom``."""
    from scipy.spatial import cKDTree

    guides = np.asarray(guides, dtype=np.int64).reshape(-1)
    if guides.size == 0:
        raise UsageError("no guides given")
    if guides.min() < 0 or guides.max() >= groom.num_strands:
        raise UsageError(f"guide indices must be in 0..{groom.num_strands - 1}")
    if len(np.unique(guides)) != len(guides):
        raise UsageError("guide indices must be distinct")
    K = len(guides)
    frames = root_frames(groom)
    roots = groom.roots.astype(np.float64)
    groots = roots[guides]
    gframes = frames[guides]
    normals = frames[:, 2]
    S = len(roots)
    tree = cKDTree(groots)

    # single strand: nearest guide, offset in its root frame
    _, near = tree.query(roots)
    near = np.asarray(near, dtype=np.int64)
    offset = np.einsum("sij,sj->si", gframes[near], roots - groots[near])

    # multi strand
    kc = min(int(candidates), K)
    if kc >= 3:
        _, cand = tree.query(roots, k=kc)
        cand = np.asarray(cand, dtype=np.int64).reshape(S, kc)
        triples = np.array(list(combinations(range(kc), 3)))  # (T, 3), nearest first
        tri = cand[:, triples]  # (S, T, 3)
        a, b, c = groots[tri[..., 0]], groots[tri[..., 1]], groots[tri[..., 2]]
        p = np.broadcast_to(roots[:, None, :], a.shape)
        bary, ok = _barycentric(p, a, b, c)
        tn = np.cross(b - a, c - a)
        tn /= np.maximum(np.linalg.norm(tn, axis=-1, keepdims=True), 1e-30)
        facing = np.abs((tn * normals[:, None, :]).sum(-1)) > 0.5
        inside_t = ok & facing & (bary.min(axis=-1) >= -1e-9)
        size = np.maximum.reduce([np.linalg.norm(a - p, axis=-1), np.linalg.norm(b - p, axis=-1),
                                  np.linalg.norm(c - p, axis=-1)])
        score = np.where(inside_t, size, np.inf)
        best = np.argmin(score, axis=1)
        inside = np.isfinite(score[np.arange(S), best])
        best = np.where(inside, best, 0)  # fallback: the 3 nearest (triple 0)
        idx = tri[np.arange(S), best]
        w = bary[np.arange(S), best]
        w0_ok = ok[np.arange(S), best]
        w = np.clip(w, 0.0, None)
        sums = w.sum(axis=1, keepdims=True)
        bad = (~w0_ok) | (sums[:, 0] <= 1e-12)
        w = np.where(bad[:, None], 0.0, w / np.where(sums > 0, sums, 1.0))
        if bad.any():  # degenerate triangle: inverse-distance weights
            dd = np.linalg.norm(groots[idx[bad]] - roots[bad][:, None, :], axis=-1)
            inv = 1.0 / np.maximum(dd, 1e-9)
            w[bad] = inv / inv.sum(axis=1, keepdims=True)
    else:
        _, cand = tree.query(roots, k=kc)
        cand = np.asarray(cand, dtype=np.int64).reshape(S, kc)
        idx = np.concatenate([cand, np.repeat(cand[:, :1], 3 - kc, axis=1)], axis=1)
        dd = np.linalg.norm(groots[cand] - roots[:, None, :], axis=-1)
        inv = 1.0 / np.maximum(dd, 1e-9)
        w = np.zeros((S, 3))
        w[:, :kc] = inv / inv.sum(axis=1, keepdims=True)
        inside = np.zeros(S, dtype=bool)
    # heaviest first
    order = np.argsort(-w, axis=1, kind="stable")
    idx = np.take_along_axis(idx, order, axis=1)
    w = np.take_along_axis(w, order, axis=1)
    w /= w.sum(axis=1, keepdims=True)
    blend = np.einsum("sk,skj->sj", w, groots[idx])
    multi_offset = np.einsum("sij,sj->si", gframes[idx[:, 0]], roots - blend)
    return GuideWeights(
        guides=guides,
        indices=idx.astype(np.int32),
        weights=w.astype(np.float32),
        inside=inside,
        guide=near.astype(np.int32),
        offset=offset.astype(np.float32),
        multi_offset=multi_offset.astype(np.float32),
        guide_frames=gframes.astype(np.float32),
    )


def make_guides(groom: Groom, k: int, method: str = "fps", seed: int = 0) -> GuideWeights:
    """Choose ``k`` guides of ``groom`` and compute every strand's interpolation data."""
    if groom.num_strands == 0:
        raise GroomError("the groom has no strands")
    return compute_guide_weights(groom, select_guides(groom, k, method, seed))


# ---------------------------------------------------------------------------- reconstruction


def _tangents(p: np.ndarray) -> np.ndarray:
    t = np.empty_like(p)
    t[:, 1:-1] = p[:, 2:] - p[:, :-2]
    t[:, 0] = p[:, 1] - p[:, 0]
    t[:, -1] = p[:, -1] - p[:, -2]
    return t / np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-30)


def _carry(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotate x (..., 3) by the smallest rotation from unit a to unit b (same shapes)."""
    v = np.cross(a, b)
    c = (a * b).sum(-1, keepdims=True)
    k = 1.0 / np.maximum(1.0 + c, 1e-6)
    return x * c + np.cross(v, x) + v * ((v * x).sum(-1, keepdims=True) * k)


def reconstruct(guide_points: np.ndarray, weights: GuideWeights, method: str = "multi",
                guide_frames: np.ndarray | None = None) -> np.ndarray:
    """(S, N, 3) render strands from (K, N, 3) guide points (the interpolation shader's twin).

    method: ``'single'`` (nearest guide plus its rotated offset) or ``'multi'`` (barycentric
    blend of 3 guides plus the rotated root correction). guide_frames: (K, 3, 3) current root
    frames of the guides (rows t, b, n); by default the rest frames in ``weights``.
    """
    g = np.asarray(guide_points, dtype=np.float64)
    if g.ndim != 3 or g.shape[2] != 3 or g.shape[1] < 2:
        raise UsageError(f"guide points must have shape (K, N>=2, 3), got {g.shape}")
    if len(g) != weights.num_guides:
        raise UsageError(f"{len(g)} guides given but the weights were made for {weights.num_guides}")
    F = np.asarray(weights.guide_frames if guide_frames is None else guide_frames, dtype=np.float64)
    T = _tangents(g)  # (K, N, 3)
    T0 = np.broadcast_to(T[:, :1], T.shape)
    if method == "single":
        gi = weights.guide.astype(np.int64)
        o = np.einsum("si,sij->sj", weights.offset.astype(np.float64), F[gi])  # world, at root
        o = np.broadcast_to(o[:, None, :], (len(gi), g.shape[1], 3))
        return g[gi] + _carry(o, T0[gi], T[gi])
    if method != "multi":
        raise UsageError(f"unknown interpolation {method!r}; use 'single' or 'multi'")
    idx = weights.indices.astype(np.int64)
    w = weights.weights.astype(np.float64)
    blend = np.einsum("sk,sknj->snj", w, g[idx])
    h = idx[:, 0]
    o = np.einsum("si,sij->sj", weights.multi_offset.astype(np.float64), F[h])
    o = np.broadcast_to(o[:, None, :], blend.shape)
    return blend + _carry(o, T0[h], T[h])


__all__ = ["GuideWeights", "select_guides", "farthest_point_guides", "compute_guide_weights",
           "make_guides", "reconstruct", "root_frames"]
