"""A cheap signed distance to a mesh, for keeping grown hair out of the head.

The surface is represented by samples (its vertices with their normals, and every face's
centroid with the face normal) in a KD-tree. The signed distance of a point is its offset from
the nearest sample along that sample's normal: exact on flat patches, within about
``edge² × curvature`` elsewhere, and fine at the few-millimetre scale of a hair's clearance.
Good for growth, not for physics.
"""
from __future__ import annotations

import numpy as np

from ..mesh import Mesh


class SurfaceProximity:
    """Nearest-sample signed distance to a mesh and a push-out along the surface normal."""

    def __init__(self, mesh: Mesh, reach: float = 0.015):
        """``reach`` (m): points farther than this from every surface sample count as outside
        (a bound that keeps KD-tree queries fast; hair steps are much shorter)."""
        from scipy.spatial import cKDTree

        tri = mesh.triangles
        fn = mesh.face_normals()
        good = np.linalg.norm(fn, axis=1) > 0
        self.points = np.concatenate([mesh.vertices.astype(np.float64), tri[good].mean(axis=1)])
        self.normals = np.concatenate([mesh.normals.astype(np.float64), fn[good]])
        self.tree = cKDTree(self.points)
        self.reach = float(reach)

    def signed_distance(self, p: np.ndarray, reach: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(N,) signed distances (negative inside) and the (N, 3) normals they were measured on.

        Points beyond ``reach`` of every sample get +inf and a zero normal.
        """
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        _, idx = self.tree.query(p, distance_upper_bound=self.reach if reach is None else reach)
        far = idx >= len(self.points)
        idx = np.where(far, 0, idx)
        n = np.where(far[:, None], 0.0, self.normals[idx])
        d = np.where(far, np.inf, ((p - self.points[idx]) * n).sum(axis=1))
        return d, n

    def push_out(self, p: np.ndarray, margin: float = 0.0, reach: float | None = None) -> np.ndarray:
        """Points moved along the nearest surface normal until at least ``margin`` outside."""
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        d, n = self.signed_distance(p, reach)
        lift = np.maximum(margin - d, 0.0)
        return p + lift[:, None] * n


__all__ = ["SurfaceProximity"]
