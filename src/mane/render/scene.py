"""The procedural default scene: grooming's default head and a groom grown on its scalp.

``default_scene`` uses ``mane.grooming``'s ``grow`` when it is there; otherwise a small grower
here (roots on the painted scalp, strands that leave along the normal, bend under gravity and
are pushed out of the head's distance field) keeps the renderer usable on its own.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..groom import Groom


@lru_cache(maxsize=4)
def _head(subdivisions: int):
    from ..grooming.head import default_head

    return default_head(subdivisions)


def default_head(subdivisions: int = 4):
    """The default bust (cached per subdivision level; 4 gives 5,120 triangles)."""
    return _head(int(subdivisions))


def simple_grow(head, num_guides: int = 600, points: int = 16, length: float = 0.2,
                seed: int = 7) -> Groom:
    """Straight-ish shoulder-length hair combed back and down, kept off the head's surface."""
    from ..grooming.head import head_sdf, scalp_weight

    rng = np.random.default_rng(seed)
    v = head.vertices.astype(np.float64)
    n = head.normals.astype(np.float64)
    w = head.vertex_attributes.get("scalp")
    w = scalp_weight(v) if w is None else np.asarray(w, np.float64)
    cand = np.flatnonzero(w > 0.5)
    if len(cand) == 0:
        raise ValueError("the head has no scalp to grow hair on")
    pick = rng.choice(cand, size=num_guides, replace=len(cand) < num_guides)
    # jitter the roots inside the neighbouring triangles' span
    roots = v[pick] + rng.normal(scale=0.002, size=(len(pick), 3))
    normals = n[pick]
    S = len(pick)
    seg = length * rng.uniform(0.85, 1.15, size=S) / (points - 1)
    pts = np.zeros((S, points, 3))
    pts[:, 0] = roots
    # comb: away from the parting (the x = 0 line), backward and down, in the scalp's tangent plane
    comb = np.stack([np.sign(roots[:, 0] + 1e-6) * 0.45, -0.3 * np.ones(S), -1.0 * np.ones(S)], axis=1)
    comb -= normals * np.sum(comb * normals, axis=1, keepdims=True)
    comb /= np.maximum(np.linalg.norm(comb, axis=1, keepdims=True), 1e-9)
    d = 0.45 * normals + comb
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    gravity = np.array([0.0, -1.0, 0.0])
    cushion = 0.004 + 0.012 * rng.uniform(size=S)   # volume: strands rest at different heights

    def sdf_grad(p, h=1e-4):
        g = np.stack([(head_sdf(p + h * e) - head_sdf(p - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
        return g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)

    for k in range(1, points):
        t = k / (points - 1)
        d = d + gravity * 0.35 + rng.normal(scale=0.04, size=(S, 3))
        front = pts[:, k - 1, 2] > -0.02          # keep the face clear: drift back and aside
        d[front] += np.stack([np.sign(pts[front, k - 1, 0]) * 0.25, np.zeros(front.sum()),
                              -0.5 * np.ones(front.sum())], axis=1)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        p = pts[:, k - 1] + d * seg[:, None]
        want = cushion * (0.3 + t)
        for _ in range(4):   # push out of the head
            dist = head_sdf(p)
            inside = dist < want
            if not inside.any():
                break
            grad = sdf_grad(p[inside])
            p[inside] += grad * (want[inside] - dist[inside])[:, None]
        step = p - pts[:, k - 1]   # keep the segment length
        step *= (seg / np.maximum(np.linalg.norm(step, axis=1), 1e-12))[:, None]
        pts[:, k] = pts[:, k - 1] + step
        d = step / np.linalg.norm(step, axis=1, keepdims=True)
    return Groom(pts.reshape(-1, 3).astype(np.float32), np.full(S, points, np.int32),
                 metadata={"source": "mane.render.scene.simple_grow"})


def default_groom(head=None, num_guides: int = 600, points: int = 16) -> Groom:
    """A groom on the default head: grooming's ``grow`` if available, else ``simple_grow``."""
    head = head if head is not None else default_head()
    try:
        from ..grooming import grow  # written by helper-grooming
    except ImportError:
        grow = None
    if grow is not None:
        for kwargs in ({"num_guides": num_guides, "points_per_strand": points}, {"num_guides": num_guides}, {}):
            try:
                g = grow(head, **kwargs)
            except TypeError:
                continue
            g = getattr(g, "groom", g)
            if isinstance(g, Groom):
                return g
    return simple_grow(head, num_guides, points)


def default_scene(num_guides: int = 600, points: int = 16, subdivisions: int = 4):
    """(groom, head) of the procedural default."""
    head = default_head(subdivisions)
    return default_groom(head, num_guides, points), head
