"""The SDF bake as it was before the NumPy-only bake (mane.sim.sdf_bake), kept verbatim as the
tests' reference: surface samples on a lattice no coarser than h / 2, SciPy's k-d tree for the 4
nearest samples of each node within 2.5 h and exact distances to their triangles (exact where the
nearest triangle is among them, never more than h / 2 too large), SciPy's distance transform for
the farther nodes (the distance to the closest point of the nearest band node), and the sign by a
majority of three ray-parity votes. ``closest_points_on_triangles`` (Ericson 5.1.5) is also the
tests' brute-force exact distance."""
from __future__ import annotations

import numpy as np

from mane.errors import GroomError, UsageError


def closest_points_on_triangles(p, a, b, c):
    """Closest points (n, 3) on triangles (a, b, c) to points p, all (n, 3) (Ericson 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1 = np.einsum("ij,ij->i", ab, ap)
    d2 = np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3 = np.einsum("ij,ij->i", ab, bp)
    d4 = np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5 = np.einsum("ij,ij->i", ab, cp)
    d6 = np.einsum("ij,ij->i", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2

    def div(x, y):
        return np.divide(x, y, out=np.zeros_like(x), where=y != 0)

    v_ab = div(d1, d1 - d3)
    w_ac = div(d2, d2 - d6)
    w_bc = div(d4 - d3, (d4 - d3) + (d5 - d6))
    s = va + vb + vc
    v_in = div(vb, s)
    w_in = div(vc, s)
    conditions = [
        (d1 <= 0) & (d2 <= 0),
        (d3 >= 0) & (d4 <= d3),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),
        (d6 >= 0) & (d5 <= d6),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0),
    ]
    choices = [a, b, a + v_ab[:, None] * ab, c, a + w_ac[:, None] * ac, b + w_bc[:, None] * (c - b)]
    out = a + v_in[:, None] * ab + w_in[:, None] * ac
    for cond, choice in zip(reversed(conditions), reversed(choices)):
        out = np.where(cond[:, None], choice, out)
    return out


def surface_samples(triangles: np.ndarray, spacing: float, max_points: int = 20_000_000):
    """Points on a triangular lattice over each triangle, no farther apart than ``spacing``.

    Returns (points (M, 3), triangle index (M,))."""
    t = np.asarray(triangles, np.float64)
    edges = np.stack([np.linalg.norm(t[:, 1] - t[:, 0], axis=1), np.linalg.norm(t[:, 2] - t[:, 1], axis=1),
                      np.linalg.norm(t[:, 0] - t[:, 2], axis=1)], axis=1).max(axis=1)
    n = np.maximum(1, np.ceil(edges / spacing)).astype(np.int64)
    total = int(((n + 1) * (n + 2) // 2).sum())
    if total > max_points:
        raise UsageError(f"SDF bake would need {total} surface samples; lower the resolution "
                         "or simplify the mesh")
    points, owners = [], []
    for k in np.unique(n):
        tri = np.nonzero(n == k)[0]
        a, b = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = a + b <= k
        ua, ub = a[keep] / k, b[keep] / k                     # (L,)
        t0, t1, t2 = t[tri, 0], t[tri, 1], t[tri, 2]
        pts = (t0[:, None] + ua[None, :, None] * (t1 - t0)[:, None] + ub[None, :, None] * (t2 - t0)[:, None])
        points.append(pts.reshape(-1, 3))
        owners.append(np.repeat(tri, len(ua)))
    return np.concatenate(points), np.concatenate(owners)


def _parity_inside(triangles, lo, h, shape, axis):
    """Inside (odd crossings) per node from rays along ``axis`` through the node columns."""
    b_ax, c_ax = [a for a in range(3) if a != axis]
    nb, nc, na = shape[b_ax], shape[c_ax], shape[axis]
    jitter = h * np.array([1.234567e-4, 2.345678e-4])     # keep rays off edges and vertices
    t = np.asarray(triangles, np.float64)
    P = (t[:, :, [b_ax, c_ax]] - np.array([lo[b_ax], lo[c_ax]]) - jitter) / h   # (F, 3, 2) in columns
    A = (t[:, :, axis] - lo[axis]) / h                                        # (F, 3) along the ray
    i0 = np.clip(np.ceil(P[:, :, 0].min(axis=1)), 0, nb).astype(np.int64)
    i1 = np.clip(np.floor(P[:, :, 0].max(axis=1)), -1, nb - 1).astype(np.int64)
    j0 = np.clip(np.ceil(P[:, :, 1].min(axis=1)), 0, nc).astype(np.int64)
    j1 = np.clip(np.floor(P[:, :, 1].max(axis=1)), -1, nc - 1).astype(np.int64)
    ni = np.maximum(i1 - i0 + 1, 0)
    nj = np.maximum(j1 - j0 + 1, 0)
    counts = ni * nj
    crossings = np.zeros((nb * nc, na + 1), np.int32)
    tri = np.repeat(np.arange(len(t)), counts)
    if len(tri):
        start = np.repeat(np.cumsum(counts) - counts, counts)
        local = np.arange(len(tri)) - start
        ci = i0[tri] + local // nj[tri]
        cj = j0[tri] + local % nj[tri]
        q = np.stack([ci, cj], axis=1).astype(np.float64)
        p0, p1, p2 = P[tri, 0], P[tri, 1], P[tri, 2]

        def edge(u, v, w):
            return (v[:, 0] - u[:, 0]) * (w[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (w[:, 0] - u[:, 0])

        w0 = edge(p1, p2, q)
        w1 = edge(p2, p0, q)
        w2 = edge(p0, p1, q)
        area = w0 + w1 + w2
        hit = (area != 0) & (((w0 >= 0) & (w1 >= 0) & (w2 >= 0)) | ((w0 <= 0) & (w1 <= 0) & (w2 <= 0)))
        s = np.where(hit, area, 1.0)
        depth = (w0 * A[tri, 0] + w1 * A[tri, 1] + w2 * A[tri, 2]) / s
        k = np.clip(np.ceil(depth[hit]), 0, na).astype(np.int64)
        col = (ci * nc + cj)[hit]
        np.add.at(crossings, (col, k), 1)
    below = np.cumsum(crossings, axis=1)[:, :na]                     # crossings below node k
    inside = (below % 2 == 1).reshape(nb, nc, na)
    order = np.argsort([b_ax, c_ax, axis])
    return inside.transpose(order)


def near_samples(points, lo, h, shape, reach: int) -> np.ndarray:
    """(shape) bool: the nodes from ``reach`` below to ``reach + 1`` above the cell of a point on
    every axis (reach 2: every node within 2.5 h of a point, whatever its place in its cell)."""
    cell = np.clip(np.floor((points - lo) / h).astype(np.int64), 0, np.array(shape) - 1)
    mark = np.zeros(shape, bool)
    mark[cell[:, 0], cell[:, 1], cell[:, 2]] = True
    for axis in range(3):   # separable dilation by [-reach, reach + 1] nodes along each axis
        m = np.moveaxis(mark, axis, 0)
        grown = m.copy()
        n = m.shape[0]
        for o in range(1, reach + 2):
            grown[o:] |= m[:n - o]
            if o <= reach:
                grown[:n - o] |= m[o:]
        mark = np.moveaxis(grown, 0, axis)
    return mark


def bake_sdf(vertices, faces, resolution: int = 64, padding: float = 0.05):
    """(values (nx, ny, nz) float32 indexed [i, j, k], lo (3,) float64, h) of a closed mesh."""
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    if len(f) == 0:
        raise GroomError("cannot bake an SDF of a mesh without faces")
    resolution = int(resolution)
    if not 4 <= resolution <= 512:
        raise UsageError(f"SDF resolution must be in 4..512 (32..128 is usual), got {resolution}")
    if padding < 0:
        raise UsageError(f"SDF padding must be >= 0 (metres), got {padding}")
    mn, mx = v.min(axis=0), v.max(axis=0)
    side = float((mx - mn).max())
    if side <= 0:
        raise GroomError("the mesh has no extent")
    full = side + 2.0 * padding
    h = full / (resolution - 1)
    shape = tuple(int(min(resolution, np.ceil((mx[a] - mn[a] + 2 * padding) / h - 1e-9) + 1))
                  for a in range(3))
    centre = 0.5 * (mn + mx)
    lo = centre - 0.5 * (np.array(shape) - 1) * h
    tris = v[f]

    # unsigned distance near the surface: nearest lattice samples, then exact distance to their
    # triangles; farther out: distance to the nearest band node plus that node's distance
    points, owner = surface_samples(tris, 0.5 * h)
    tree = cKDTree(points)
    idx = np.indices(shape).reshape(3, -1).T
    nodes = lo + idx * h
    band = 2.0 * h
    k = min(4, len(points))
    # only nodes with a sample within the query's bound (2.5 h: near_samples' reach 2) can find
    # one; the others keep "none found" (len(points)), as the query would give them
    near = np.full((len(nodes), k), len(points), dtype=np.int64)
    cand = np.nonzero(near_samples(points, lo, h, shape, 2).reshape(-1))[0]
    if len(cand):
        _, found = tree.query(nodes[cand], k=k, distance_upper_bound=band + 0.5 * h, workers=-1)
        near[cand] = found.reshape(len(cand), k)
    best = np.full(len(nodes), np.inf)
    closest = np.zeros_like(nodes)
    for j in range(k):
        ok = near[:, j] < len(points)
        t = owner[near[ok, j]]
        cp = closest_points_on_triangles(nodes[ok], tris[t, 0], tris[t, 1], tris[t, 2])
        dist = np.linalg.norm(nodes[ok] - cp, axis=1)
        better = dist < best[ok]
        rows = np.nonzero(ok)[0][better]
        best[rows] = dist[better]
        closest[rows] = cp[better]
    in_band = best <= band
    if not in_band.all():
        from scipy.ndimage import distance_transform_edt

        if not in_band.any():
            raise GroomError("the SDF band is empty (is the mesh degenerate?)")
        nearest = distance_transform_edt(~in_band.reshape(shape), return_distances=False,
                                         return_indices=True)
        flat_nearest = np.ravel_multi_index(tuple(nearest.reshape(3, -1)), shape)
        far = ~in_band
        best[far] = np.linalg.norm(nodes[far] - closest[flat_nearest[far]], axis=1)
    # sign: majority of three ray-parity votes
    votes = sum(_parity_inside(tris, lo, h, shape, a).astype(np.int8) for a in range(3))
    inside = votes.reshape(-1) >= 2
    values = np.where(inside, -best, best).reshape(shape).astype(np.float32)
    return values, lo, float(h)
