"""Signed distance fields of head and body meshes, and particle collisions against them.

    sdf = MeshSDF.bake(ctx, head_mesh, resolution=64, padding=0.05)
    sdf.sample(points)                       # NumPy trilinear, the twin of the shaders
    sdf.collide(positions, prev_positions, n, head_to_world, margin=0.003, friction=0.2)
    sdf.collide(state, head_to_world, 0.003, 0.2)          # the same with a SimState

**Baking** (CPU, NumPy, ``sdf_bake.bake_sdf``; 64^3 of the sim bench's 2208-triangle head in
~0.12 s of one core): cubic voxels of size h = (largest side of the padded box) /
(resolution - 1), node (i, j, k) at lo + (i, j, k) h in the mesh's own frame; the exact
unsigned distance within 3 h of the surface, farther out the distance to the closest surface
point of the nearest band node (never too small); the sign by a majority of three ray-parity
votes (x, y, z). Meshes should be closed (the procedural head is). sdf_bake.py says more.

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
from ..errors import UsageError
from ..phases import phase
from .bounds import check_particle_buffers, groups, is_state, set_uniforms, storage_barrier
from .bindings import B_POSITIONS, B_PREV_POSITIONS, TEX_SDF_FIRST
from .sdf_bake import bake_sdf

HERE = Path(__file__).resolve().parent
_CODE = disk_cache.file_hash(__file__, HERE / "sdf_bake.py")   # the bake's code: part of a cached field's key
SDF_TEXTURE_UNIT = TEX_SDF_FIRST


def bake_sdf_cached(vertices, faces, resolution: int = 64, padding: float = 0.05):
    """``bake_sdf`` through the disk cache (``mane.disk_cache``): keyed by the mesh's vertices and
    faces, the resolution, the padding and the code of this file and sdf_bake.py, so a second run of
    the same head reads the field instead of baking it."""
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
