"""Follicles: where strands are rooted on a mesh, and the local frame each one grows from.

Two samplers, both deterministic by seed:

- ``uniform``: a triangle chosen with probability proportional to its area, then a uniform
  point in it from barycentrics ``(1 - sqrt(r1), sqrt(r1) (1 - r2), sqrt(r1) r2)``.
- ``blue_noise``: Poisson-disk samples. Many uniform candidates are thinned by dart throwing
  in a random order (the lexicographically first maximal independent set of the "closer than
  r" graph, found in parallel rounds over a KD-tree's pairs), with r chosen from the region's
  area; extra samples are dropped closest-first. Every pair ends at least ``min_distance``
  apart (straight-line distance).

A region restricts where follicles go: a painted vertex-colour channel (``VertexColorRegion``),
a face set (indices or a boolean mask over faces), or a predicate on positions and normals
(``NormalCone``, ``AbovePlane``, ``AllOf``, or any callable). Per-sample tests are applied by
rejection, so the density stays uniform per unit area inside the region.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Union

import numpy as np

from ..errors import GroomError, UsageError
from ..mesh import Mesh

Predicate = Callable[[np.ndarray, np.ndarray], np.ndarray]


# ---------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class Follicles:
    """N follicles on a mesh (float64 arrays, metres).

    positions: (N, 3) roots on the surface. normals: (N, 3) unit, interpolated vertex normals.
    tangents, bitangents: (N, 3) unit; (tangent, bitangent, normal) is a right-handed frame
    (see ``frame_from_normal``). face_index: (N,) int64 triangle of each root.
    barycentrics: (N, 3) weights of that triangle's corners. min_distance: the guaranteed
    spacing of blue-noise samples in metres (None for uniform sampling).
    """

    positions: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    bitangents: np.ndarray
    face_index: np.ndarray
    barycentrics: np.ndarray
    min_distance: float | None = None

    def __len__(self) -> int:
        return len(self.positions)

    @property
    def frames(self) -> np.ndarray:
        """(N, 3, 3): rows tangent, bitangent, normal (world = local @ frame)."""
        return np.stack([self.tangents, self.bitangents, self.normals], axis=1)

    def subset(self, idx) -> "Follicles":
        idx = np.asarray(idx)
        return Follicles(self.positions[idx], self.normals[idx], self.tangents[idx],
                         self.bitangents[idx], self.face_index[idx], self.barycentrics[idx],
                         self.min_distance)


def frame_from_normal(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and bitangent for unit normals (..., 3), smooth everywhere except at n = -Y.

    Frisvad's basis in a cyclically permuted frame whose pole is -Y, so on a head the one
    singular direction points at the floor. At the crown (n = +Y) the tangent is +Z and the
    bitangent +X; (tangent, bitangent, n) is right-handed.
    """
    n = np.asarray(n, dtype=np.float64)
    x, y, z = n[..., 2], n[..., 0], n[..., 1]  # permuted: (z, x, y)
    zc = np.maximum(z, -1.0 + 1e-9)
    a = 1.0 / (1.0 + zc)
    b = -x * y * a
    b1 = np.stack([1.0 - x * x * a, b, -x], axis=-1)
    b2 = np.stack([b, 1.0 - y * y * a, -y], axis=-1)
    # back from permuted (w0, w1, w2) to world (w1, w2, w0)
    t = b1[..., [1, 2, 0]]
    bt = b2[..., [1, 2, 0]]
    pole = z < -1.0 + 1e-6  # at the singular direction itself: any orthonormal pair
    if np.any(pole):
        t = np.where(pole[..., None], [0.0, 0.0, 1.0], t)
        t = t - (t * n).sum(axis=-1, keepdims=True) * n
        bt = np.where(pole[..., None], np.cross(n, t), bt)
    t /= np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-30)
    bt /= np.maximum(np.linalg.norm(bt, axis=-1, keepdims=True), 1e-30)
    return t, bt


# ---------------------------------------------------------------------------- regions


@dataclass(frozen=True)
class VertexColorRegion:
    """Where a vertex-colour channel, interpolated over each triangle, reaches ``threshold``.

    channel: 0..3 (red holds the default head's scalp weight). threshold: in [0, 1].
    """

    channel: int = 0
    threshold: float = 0.5


@dataclass(frozen=True)
class NormalCone:
    """Points whose normal lies within ``half_angle`` (radians) of ``direction``."""

    direction: tuple[float, float, float] = (0.0, 1.0, 0.0)
    half_angle: float = np.pi / 3

    def __call__(self, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
        d = np.asarray(self.direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        return normals @ d >= np.cos(self.half_angle)


@dataclass(frozen=True)
class AbovePlane:
    """Points on the side of the plane through ``point`` that ``normal`` points to (metres)."""

    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    normal: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def __call__(self, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
        return (positions - np.asarray(self.point, dtype=np.float64)) @ np.asarray(
            self.normal, dtype=np.float64) >= 0.0


@dataclass(frozen=True)
class AllOf:
    """Points that every predicate accepts."""

    predicates: tuple

    def __call__(self, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
        keep = np.ones(len(positions), dtype=bool)
        for p in self.predicates:
            keep &= np.asarray(p(positions, normals), dtype=bool)
        return keep


Region = Union[None, VertexColorRegion, np.ndarray, list, Predicate]


def _resolve_region(mesh: Mesh, region) -> tuple[np.ndarray, Callable | None, str]:
    """Candidate faces (bool, F) and a per-sample test (or None); a description for messages."""
    F = len(mesh.faces)
    if region is None:
        return np.ones(F, dtype=bool), None, "the whole mesh"
    if isinstance(region, VertexColorRegion):
        if mesh.colors is None:
            raise GroomError("the region asks for a painted vertex-colour channel but the mesh "
                             "has no vertex colours; paint a scalp or pass faces or a predicate")
        if not 0 <= region.channel < mesh.colors.shape[1]:
            raise UsageError(f"colour channel {region.channel} out of range 0..{mesh.colors.shape[1] - 1}")
        w = mesh.colors[:, region.channel].astype(np.float64)
        faces = w[mesh.faces].max(axis=1) >= region.threshold
        wf = w[mesh.faces]

        def test(face, bary, positions, normals):
            return (wf[face] * bary).sum(axis=1) >= region.threshold

        return faces, test, f"colour channel {region.channel} >= {region.threshold}"
    if callable(region):
        def test(face, bary, positions, normals):
            keep = np.asarray(region(positions, normals), dtype=bool)
            if keep.shape != (len(positions),):
                raise UsageError(f"a region predicate must return ({len(positions)},) bools, got {keep.shape}")
            return keep

        return np.ones(F, dtype=bool), test, f"the predicate {region!r}"
    arr = np.asarray(region)
    if arr.dtype == bool:
        if arr.shape != (F,):
            raise UsageError(f"a face mask must have shape ({F},), got {arr.shape}")
        return arr.copy(), None, "the face mask"
    if arr.size == 0:
        return np.zeros(F, dtype=bool), None, "an empty face set"
    if not np.issubdtype(arr.dtype, np.integer):
        raise UsageError("a region must be a VertexColorRegion, face indices, a face mask or a predicate")
    if arr.min() < 0 or arr.max() >= F:
        raise UsageError(f"face indices must be in 0..{F - 1}")
    mask = np.zeros(F, dtype=bool)
    mask[arr.reshape(-1)] = True
    return mask, None, "the face set"


# ---------------------------------------------------------------------------- sampling


class _Sampler:
    """Uniform-by-area samples on a mesh restricted to a region (rejection for per-sample tests)."""

    def __init__(self, mesh: Mesh, region, rng: np.random.Generator):
        self.mesh = mesh
        self.rng = rng
        faces, self.test, self.what = _resolve_region(mesh, region)
        areas = mesh.face_areas() * faces
        self.face_ids = np.flatnonzero(areas > 0)
        if self.face_ids.size == 0:
            raise GroomError(f"no faces with area in {self.what}: nothing to grow hair on")
        self.cdf = np.cumsum(areas[self.face_ids])
        self.area = float(self.cdf[-1])
        self.tri = mesh.triangles
        self.vn = mesh.normals.astype(np.float64)
        self.fn = mesh.face_normals()
        self.accept_rate = 1.0

    def _draw(self, n: int):
        rng = self.rng
        pick = np.searchsorted(self.cdf, rng.random(n) * self.area, side="right")
        face = self.face_ids[np.minimum(pick, len(self.face_ids) - 1)]
        r1, r2 = rng.random(n), rng.random(n)
        s = np.sqrt(r1)
        bary = np.stack([1.0 - s, s * (1.0 - r2), s * r2], axis=1)
        pos = np.einsum("nk,nkj->nj", bary, self.tri[face])
        nrm = np.einsum("nk,nkj->nj", bary, self.vn[self.mesh.faces[face]])
        length = np.linalg.norm(nrm, axis=1, keepdims=True)
        bad = length[:, 0] < 1e-8
        nrm = np.where(bad[:, None], self.fn[face], nrm / np.maximum(length, 1e-30))
        return face, bary, pos, nrm

    def sample(self, n: int):
        """Exactly n samples (face, bary, position, normal), in draw order."""
        if self.test is None:
            return self._draw(n)
        parts, got = [], 0
        for _ in range(64):
            want = n - got
            batch = int(min(max(1.25 * want / max(self.accept_rate, 1e-3) + 64, 256), 4e6))
            face, bary, pos, nrm = self._draw(batch)
            keep = self.test(face, bary, pos, nrm)
            self.accept_rate = max(float(keep.mean()), 1e-4)
            parts.append((face[keep], bary[keep], pos[keep], nrm[keep]))
            got += int(keep.sum())
            if got >= n:
                break
        if got < n:
            raise GroomError(f"{self.what} accepts almost no point of the mesh: "
                             f"found {got} of {n} follicles")
        return tuple(np.concatenate([p[k] for p in parts])[:n] for k in range(4))

    def region_area(self) -> float:
        """The region's area (m²), estimated by the rejection rate when there is a test."""
        if self.test is None:
            return self.area
        face, bary, pos, nrm = self._draw(20000)
        return self.area * max(float(self.test(face, bary, pos, nrm).mean()), 1e-4)


def _first_independent_set(n: int, pairs: np.ndarray) -> np.ndarray:
    """Greedy maximal independent set in index order, computed in parallel rounds.

    Equals dart throwing that visits the points 0, 1, 2, ... and keeps a point when no kept
    point is closer than r (``pairs`` holds the i < j pairs closer than r).
    """
    state = np.zeros(n, dtype=np.int8)  # 0 undecided, 1 kept, -1 rejected
    i, j = pairs[:, 0], pairs[:, 1]
    while True:
        und = state == 0
        if not und.any():
            break
        live = und[i] & und[j]
        i, j = i[live], j[live]
        blocked = np.zeros(n, dtype=bool)
        blocked[j] = True  # j has an undecided neighbour that comes first
        new = und & ~blocked
        state[new] = 1
        hit = new[i]
        state[j[hit]] = -1
        hit = new[j]
        state[i[hit]] = -1
    return state == 1


def _blue_noise(sampler: _Sampler, count: int, min_distance: float | None, oversample: float):
    from scipy.spatial import cKDTree

    m = int(max(oversample * count, count + 64))
    if min_distance is not None:
        radius = float(min_distance)
        if not np.isfinite(radius) or radius <= 0:
            raise UsageError(f"min_distance must be positive, got {radius}")
        area = sampler.region_area()
        densest = area / (0.5 * np.sqrt(3.0) * radius * radius)  # hexagonal packing
        if count > densest:
            raise GroomError(f"{count} follicles cannot fit {radius} m apart in {sampler.what} "
                             f"(about {area:.4g} m², room for at most ~{int(densest)}); "
                             "ask for fewer or a smaller distance")
        # keep the number of close candidate pairs (memory, time) bounded
        budget = np.sqrt(2.0 * 2e7 * area / (np.pi * radius * radius))
        m = int(max(count + 64, min(m, budget)))
    face, bary, pos, nrm = sampler.sample(m)
    tree = cKDTree(pos)
    if min_distance is not None:
        keep = _first_independent_set(m, tree.query_pairs(radius, output_type="ndarray"))
        if keep.sum() < count:
            raise GroomError(f"only {int(keep.sum())} follicles fit {radius} m apart in "
                             f"{sampler.what}; ask for fewer or a smaller distance")
    else:
        # Random sequential adsorption in 2D jams at a coverage of about 0.547.
        radius = 0.80 * np.sqrt(sampler.region_area() / count)
        for _ in range(40):
            keep = _first_independent_set(m, tree.query_pairs(radius, output_type="ndarray"))
            if keep.sum() >= count:
                break
            radius *= 0.93
        else:
            raise GroomError("blue-noise sampling could not place the follicles")
    idx = np.flatnonzero(keep)
    if len(idx) > count:  # drop the most crowded extras
        d, _ = cKDTree(pos[idx]).query(pos[idx], k=2)
        order = np.argsort(-d[:, 1], kind="stable")
        idx = np.sort(idx[order[:count]])
    return face[idx], bary[idx], pos[idx], nrm[idx], radius


def sample_follicles(
    mesh: Mesh,
    count: int,
    *,
    region: Region = None,
    method: str = "uniform",
    seed: int = 0,
    min_distance: float | None = None,
    oversample: float = 5.0,
) -> Follicles:
    """``count`` follicles on ``mesh`` inside ``region``.

    method: ``"uniform"`` (area-weighted random) or ``"blue_noise"`` (Poisson disk; the spacing
    is chosen from the area unless ``min_distance`` (metres) is given). oversample: candidates
    per follicle for blue noise. Deterministic for a given seed.
    """
    count = int(count)
    if count <= 0:
        raise UsageError(f"the number of follicles must be positive, got {count}")
    if method not in ("uniform", "blue_noise"):
        raise UsageError(f"unknown sampling method {method!r}; use 'uniform' or 'blue_noise'")
    rng = np.random.default_rng(seed)
    sampler = _Sampler(mesh, region, rng)
    spacing = None
    if method == "uniform":
        face, bary, pos, nrm = sampler.sample(count)
    else:
        face, bary, pos, nrm, spacing = _blue_noise(sampler, count, min_distance, oversample)
    t, b = frame_from_normal(nrm)
    return Follicles(pos, nrm, t, b, face.astype(np.int64), bary, spacing)


__all__ = ["Follicles", "sample_follicles", "frame_from_normal", "VertexColorRegion",
           "NormalCone", "AbovePlane", "AllOf"]
