"""Signed distance fields of head and body meshes, and particle collisions against them.

    sdf = MeshSDF.bake(ctx, head_mesh, resolution=64, padding=0.05)
    sdf.sample(points)                       # NumPy trilinear, the twin of the shaders
    sdf.collide(positions, prev_positions, n, head_to_world, margin=0.003, friction=0.2)
    sdf.collide(state, head_to_world, 0.003, 0.2)          # the same with a SimState

**Baking** (CPU, NumPy/SciPy; 64^3 of a 20k-triangle head takes about a second):

- the grid: cubic voxels of size h = (largest side of the padded box) / (resolution - 1),
  ``padding`` metres being added on every side of the mesh's box; the other axes get as
  many nodes as they need (<= resolution). Node (i, j, k) sits at lo + (i, j, k) h in the
  mesh's own frame.
- unsigned distance: the surface is sampled on a triangular lattice no coarser than h / 2;
  for each node within 2 h of it, the triangles of its 4 nearest samples (cKDTree) give
  exact point-triangle distances and the least is kept (exact where the nearest triangle is
  among them, never more than h / 2 too large). Farther nodes take the distance to the
  closest surface point of their nearest band node (scipy's Euclidean distance transform
  finds it): never too small, and in practice within a small fraction of h.
- sign: ray parity along x, y and z (each triangle is rasterised onto the node columns, the
  crossings below each node counted) and a majority vote of the three, which survives rays
  that graze edges and small holes. Meshes should be closed (the procedural head is).

**Sampling**: trilinear between nodes with ``texelFetch`` (the same on every GPU, and equal
to ``sample``); outside the box, the clamped value plus the distance to the box.

**Collision** (``sdf_collide.comp``, one invocation per particle, pinned ones skipped): in the
mesh's frame (``transform`` maps mesh -> world, e.g. the head's rigid motion), a particle
with sdf < margin is moved along the normalised central-difference gradient by
margin - sdf = depth; Coulomb-style friction (position-based, as in Macklin et al. 2014)
then takes away min(|t|, friction * depth) of the tangential displacement t since
``prev_positions``, measured relative to the mesh (whose previous transform is
``prev_transform``, by default the one of the previous call): slow slides stop, fast ones
are slowed. Up to two more projections fix what friction or curvature left inside.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .. import disk_cache
from ..errors import GroomError, UsageError
from ..phases import phase
from .bounds import check_particle_buffers, groups, is_state, set_uniforms, storage_barrier
from .bindings import B_POSITIONS, B_PREV_POSITIONS, TEX_SDF_FIRST

HERE = Path(__file__).resolve().parent
_CODE = disk_cache.file_hash(__file__)   # the bake's code: part of a cached field's key
SDF_TEXTURE_UNIT = TEX_SDF_FIRST


# --------------------------------------------------------------------------- geometry
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


def bake_sdf_cached(vertices, faces, resolution: int = 64, padding: float = 0.05):
    """``bake_sdf`` through the disk cache (``mane.disk_cache``): keyed by the mesh's vertices and
    faces, the resolution, the padding and this file's code, so a second run of the same head
    reads the field instead of baking it (the bake is seconds of NumPy for a 20k-triangle head)."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    key = disk_cache.digest(v, f, int(resolution), float(padding), _CODE)
    values, lo, h = disk_cache.arrays("sdf", key, lambda: bake_sdf(v, f, resolution, padding))
    return values, lo, float(h)


def sample_grid(values, lo, h, points):
    """Trilinear sample of node values at points (clamped; plus the distance outside the box)."""
    values = np.asarray(values)
    res = np.array(values.shape)
    g = (np.asarray(points, np.float64).reshape(-1, 3) - lo) / h
    gc = np.clip(g, 0.0, res - 1)
    b = np.minimum(np.floor(gc).astype(np.int64), res - 2)
    f = gc - b
    out = np.zeros(len(g))
    for c in range(8):
        o = np.array([c & 1, (c >> 1) & 1, (c >> 2) & 1])
        w = np.prod(np.where(o == 1, f, 1.0 - f), axis=1)
        n = b + o
        out += w * values[n[:, 0], n[:, 1], n[:, 2]]
    return out + np.linalg.norm(g - gc, axis=1) * h


# --------------------------------------------------------------------------- MeshSDF
class MeshSDF:
    """A baked signed distance field (negative inside) in a mesh's own frame, with its R32F 3D texture."""

    def __init__(self, ctx, values: np.ndarray, lo, h: float):
        self.ctx = ctx
        self.values = np.ascontiguousarray(values, np.float32)
        if self.values.ndim != 3 or min(self.values.shape) < 2:
            raise UsageError(f"SDF values must be (nx, ny, nz) with every side >= 2, got {self.values.shape}")
        self.lo = np.asarray(lo, np.float64).reshape(3)
        self.h = float(h)
        self.shape = tuple(int(s) for s in self.values.shape)
        self.bake_seconds = 0.0
        self._last_transform = None
        self._collide = None
        self.texture = None
        if ctx is not None:
            # x fastest in memory: the texture's (width, height, depth) = (nx, ny, nz)
            from ..gpu.buffers import check_texture

            check_texture(ctx, self.shape, 1, 4, f"the {'x'.join(map(str, self.shape))} signed distance field",
                          reduce="Use a smaller SDF resolution")
            data = self.values.transpose(2, 1, 0).copy()
            self.texture = ctx.texture3d(self.shape, 1, data=data.tobytes(), dtype="f4")

    @classmethod
    def bake(cls, ctx, mesh, resolution: int = 64, padding: float = 0.05) -> "MeshSDF":
        """Bake ``mesh`` (a Mesh, a trimesh or (vertices, faces)); ctx None keeps it CPU-only.

        resolution: nodes along the longest axis (32..128). padding: metres around the mesh."""
        t0 = time.perf_counter()
        if isinstance(mesh, tuple):
            vertices, faces = mesh
        else:
            vertices, faces = mesh.vertices, mesh.faces
        with phase("sdf_bake"):
            values, lo, h = bake_sdf_cached(vertices, faces, resolution, padding)
        sdf = cls(ctx, values, lo, h)
        sdf.bake_seconds = time.perf_counter() - t0
        return sdf

    @property
    def hi(self) -> np.ndarray:
        return self.lo + (np.array(self.shape) - 1) * self.h

    def sample(self, points) -> np.ndarray:
        """Signed distance (metres) at points (n, 3) in the mesh's frame (the shaders' twin)."""
        return sample_grid(self.values, self.lo, self.h, points)

    def gradient(self, points) -> np.ndarray:
        """Central-difference gradient of ``sample`` (step h / 2), not normalised; the shaders'
        twin (sdf_trilinear_diff): points nearer the box's faces than the stencil reaches (half a
        node at the low faces, two at the high ones) take the gradient of the nearest point where
        it does."""
        e = 0.5 * self.h
        p = np.asarray(points, np.float64).reshape(-1, 3)
        g_lo, g_hi = 0.5, np.array(self.shape, np.float64) - 2.0
        p = self.lo + np.clip((p - self.lo) / self.h, g_lo, g_hi) * self.h
        g = np.zeros_like(p)
        for a in range(3):
            d = np.zeros(3)
            d[a] = e
            g[:, a] = (self.sample(p + d) - self.sample(p - d)) / (2 * e)
        return g

    def bind_for_sampling(self, program, unit: int = SDF_TEXTURE_UNIT) -> None:
        """Bind the texture and set the ``sdf_sample.glsl`` uniforms of ``program``."""
        if self.texture is None:
            raise UsageError("this MeshSDF was baked without a GL context")
        self.texture.use(unit)
        set_uniforms(program, sdf_texture=unit, sdf_lo=tuple(self.lo.astype(np.float32)),
                     sdf_h=self.h, sdf_res=self.shape)

    def collide(self, positions, *args, **kwargs) -> None:
        """Push particles out of the mesh, with friction (in place on ``positions``).

        ``collide(positions, prev_positions, num_particles, transform, margin, friction,
        prev_transform=None)`` or ``collide(state, transform, margin, friction, ...)``.
        transform: 4x4 mesh -> world now; prev_transform: the same at the previous step
        (default: the transform of the previous call, else ``transform``). margin: metres
        kept between particles and the surface. friction: Coulomb-style coefficient (>= 0):
        on contact, min(|t|, friction * depth) of the tangential motion t relative to the
        mesh is removed.
        """
        if is_state(positions):
            st = positions
            return self._collide_buffers(st.positions, st.prev_positions, st.num_particles, *args, **kwargs)
        return self._collide_buffers(positions, *args, **kwargs)

    def _collide_buffers(self, positions, prev_positions, num_particles: int, transform=None,
                         margin: float = 0.0, friction: float = 0.0, prev_transform=None) -> None:
        from ..gpu.glsl import compute_shader

        n = check_particle_buffers(num_particles, positions, prev_positions)
        if not friction >= 0.0:
            raise UsageError(f"SDF collision friction must be >= 0, got {friction}")
        m = np.eye(4) if transform is None else np.asarray(transform, np.float64).reshape(4, 4)
        if prev_transform is None:
            prev_transform = self._last_transform if self._last_transform is not None else m
        pm = np.asarray(prev_transform, np.float64).reshape(4, 4)
        self._last_transform = m.copy()
        if not n:
            return
        if self._collide is None:
            self._collide = compute_shader(self.ctx, HERE / "sdf_collide.comp")
        sh = self._collide
        positions.bind_to_storage_buffer(B_POSITIONS)
        prev_positions.bind_to_storage_buffer(B_PREV_POSITIONS)
        self.bind_for_sampling(sh)

        def mat(x):
            return tuple(np.asarray(x, np.float64).T.astype(np.float32).ravel())

        set_uniforms(sh, num_particles=n, world_to_local=mat(np.linalg.inv(m)), local_to_world=mat(m),
                     prev_world_to_local=mat(np.linalg.inv(pm)), margin=float(margin),
                     friction=float(friction))
        sh.run(groups(n, 128))
        storage_barrier(self.ctx)

    def collide_numpy(self, positions, prev_positions, transform=None, margin=0.0, friction=0.0,
                      prev_transform=None) -> np.ndarray:
        """CPU version of ``collide`` on (n, 4) arrays (w = inverse mass); returns new positions."""
        p = np.array(positions, np.float64)
        q = np.asarray(prev_positions, np.float64)
        m = np.eye(4) if transform is None else np.asarray(transform, np.float64)
        pm = m if prev_transform is None else np.asarray(prev_transform, np.float64)
        inv, pinv = np.linalg.inv(m), np.linalg.inv(pm)
        free = p[:, 3] != 0
        x = p[:, :3] @ inv[:3, :3].T + inv[:3, 3]
        xp = q[:, :3] @ pinv[:3, :3].T + pinv[:3, 3]
        d = self.sample(x)
        hit = free & (d < margin)
        if hit.any():
            xs = x[hit]
            nrm = self._normals(xs)
            depth = margin - d[hit]
            xs = xs + depth[:, None] * nrm
            disp = xs - xp[hit]
            tangential = disp - np.einsum("ij,ij->i", disp, nrm)[:, None] * nrm
            slip = np.linalg.norm(tangential, axis=1)
            keep = np.divide(friction * depth, slip, out=np.ones_like(slip), where=slip > 0)
            xs = xs - np.minimum(keep, 1.0)[:, None] * tangential
            for _ in range(2):
                dd = self.sample(xs)
                again = dd < margin
                if not again.any():
                    break
                xs[again] += (margin - dd[again])[:, None] * self._normals(xs[again])
            x[hit] = xs
        out = p.copy()
        out[hit, :3] = x[hit] @ m[:3, :3].T + m[:3, 3]
        return out

    def _normals(self, x):
        g = self.gradient(x)
        n = np.linalg.norm(g, axis=1, keepdims=True)
        return np.divide(g, n, out=np.zeros_like(g), where=n > 1e-12)

    def release(self) -> None:
        if self.texture is not None:
            self.texture.release()
            self.texture = None
