"""Triangle meshes for heads, bodies and colliders: vertices, faces and what hangs on them."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import GroomError


@dataclass(eq=False)
class Mesh:
    """A triangle mesh in metres, Y up.

    vertices: (V, 3) float32. faces: (F, 3) int32, counter-clockwise seen from outside.
    normals: optional (V, 3) float32 unit vertex normals (computed when absent).
    colors: optional (V, 4) float32 vertex colours in [0, 1] (a scalp region is painted here).
    vertex_attributes / face_attributes: other arrays (e.g. TressFX bone weights, face sets).
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    vertex_attributes: dict[str, np.ndarray] = field(default_factory=dict)
    face_attributes: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float32).reshape(-1, 3)
        faces = np.asarray(self.faces)
        if faces.size == 0:
            raise GroomError("the mesh has no faces")
        self.faces = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3).astype(np.int32)
        if not np.all(np.isfinite(self.vertices)):
            raise GroomError("mesh vertices contain NaN or infinite values")
        if self.faces.min() < 0 or self.faces.max() >= len(self.vertices):
            raise GroomError(
                f"mesh faces index vertices 0..{int(self.faces.max())} but there are {len(self.vertices)}"
            )
        if self.normals is None:
            self.normals = self.vertex_normals()
        else:
            self.normals = np.ascontiguousarray(self.normals, dtype=np.float32).reshape(-1, 3)
        if self.colors is not None:
            c = np.asarray(self.colors, dtype=np.float32)
            if c.ndim == 2 and c.shape[1] == 3:
                c = np.concatenate([c, np.ones((len(c), 1), np.float32)], axis=1)
            self.colors = np.ascontiguousarray(c.reshape(-1, 4))

    @property
    def triangles(self) -> np.ndarray:
        """(F, 3, 3) float64 corner positions."""
        return self.vertices.astype(np.float64)[self.faces]

    def face_normals(self) -> np.ndarray:
        """(F, 3) float64 unit normals (zero for degenerate faces)."""
        t = self.triangles
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.divide(n, length, out=np.zeros_like(n), where=length > 0)

    def face_areas(self) -> np.ndarray:
        t = self.triangles
        return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)

    def vertex_normals(self) -> np.ndarray:
        """(V, 3) float32 area-weighted vertex normals."""
        t = self.triangles
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])  # length = 2 * area
        acc = np.zeros((len(self.vertices), 3))
        for k in range(3):
            np.add.at(acc, self.faces[:, k], n)
        length = np.linalg.norm(acc, axis=1, keepdims=True)
        return np.divide(acc, length, out=np.zeros_like(acc), where=length > 0).astype(np.float32)

    def closed_outward(self) -> bool:
        """Whether the mesh is closed and wound counter-clockwise seen from outside, so that its
        back faces are never seen from outside (a renderer may cull them): every directed edge
        a -> b occurs once and b -> a once (no boundary, no flipped or non-manifold face), and the
        enclosed volume is positive."""
        f = self.faces.astype(np.int64)
        n = len(self.vertices)
        a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
        b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
        edges = np.sort(a * n + b)
        if len(edges) != len(np.unique(edges)):
            return False
        reverse = b * n + a
        i = np.searchsorted(edges, reverse)
        if not np.all((i < len(edges)) & (edges[np.minimum(i, len(edges) - 1)] == reverse)):
            return False
        t = self.vertices[self.faces].astype(np.float64)
        return bool(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() > 0.0)

    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def diagonal(self) -> float:
        lo, hi = self.bbox()
        return float(np.linalg.norm(hi.astype(np.float64) - lo))

    def transformed(self, matrix: np.ndarray) -> "Mesh":
        m = np.asarray(matrix, dtype=np.float64)
        v = self.vertices.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        n = self.normals.astype(np.float64) @ np.linalg.inv(m[:3, :3])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        return Mesh(v.astype(np.float32), self.faces, n.astype(np.float32), self.colors,
                    dict(self.vertex_attributes), dict(self.face_attributes), dict(self.metadata))

    def to_trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, vertex_normals=self.normals, process=False)

    def stats(self) -> dict:
        lo, hi = self.bbox()
        return {
            "num_vertices": int(len(self.vertices)),
            "num_faces": int(len(self.faces)),
            "area": float(self.face_areas().sum()),
            "bbox": {"min": lo.astype(float).tolist(), "max": hi.astype(float).tolist()},
            "attributes": sorted(["normals"] + (["colors"] if self.colors is not None else [])
                                 + [f"vertex:{k}" for k in self.vertex_attributes]
                                 + [f"face:{k}" for k in self.face_attributes]),
        }

    def __repr__(self) -> str:
        return f"Mesh({len(self.vertices)} vertices, {len(self.faces)} faces)"
