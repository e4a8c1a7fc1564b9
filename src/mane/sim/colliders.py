"""Collision shapes for the hair: spheres, ellipsoids, capsules (and a mesh SDF).

Each primitive is a shape in its own rigid frame (``transform``: 4x4, local -> world,
rotation + translation only) and one of two responses:

- ``mode="projection"`` (default): inside the length constraint (DFTL's sweep, as it
  places each particle; between PBD's iterations) a particle inside is moved to the
  surface (plus ``margin``), then Coulomb-style friction removes the tangential part
  ``t`` of its displacement relative to the collider over the step: all of it when
  ``|t| <= friction * depth`` (static), else ``friction * depth`` of it. DFTL then puts
  the particle back at its rest length from its leader on the contact's tangent plane,
  so lengths stay exact and the particle outside (``contact.glsl``, ``strand_solve.comp``).
- ``mode="penalty"`` (Realtime Vulkan Hair): a zero-rest-length spring pulls a particle
  inside toward the surface: ``a += stiffness * depth * normal`` (``stiffness`` in 1/s^2,
  per unit mass), added to the forces before the constraints. Softer, needs small steps.

The shapes are uploaded as a small SSBO every step, so moving ``collider.transform``
between steps (an interactive sphere) is free. ``follow_head=True`` makes the collider
ride on the head transform (``world = head @ transform``).

Depth convention (shared by the shader and ``Collider.depth``): spheres and capsules use
the exact distance to the core point/segment; an ellipsoid with radii ``a`` (plus
margin) projects radially, ``s = a * u / |u|`` with ``u = p / a`` in its local frame,
depth ``|s - p|`` when ``|u| < 1`` (inside) and normal ``normalize(s / a^2)``.

std430 layout of one collider (176 bytes), mirrored in ``collide.glsl``:
    mat4 world_to_local; mat4 prev_local_to_world;
    vec4 shape (type, mode, capsule half-height, 0); vec4 size (radii xyz, margin);
    vec4 response (friction, penalty stiffness, 0, 0)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError

SPHERE, ELLIPSOID, CAPSULE = 0, 1, 2
PROJECTION, PENALTY = 0, 1
MODES = {"projection": PROJECTION, "penalty": PENALTY}
FLOATS_PER_COLLIDER = 44
MAX_COLLIDERS = 64


def _rigid(m) -> np.ndarray:
    m = np.asarray(m, dtype=np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise UsageError("a collider transform must be a finite 4x4 matrix")
    r = m[:3, :3]
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-4) or np.linalg.det(r) < 0:
        raise UsageError("a collider transform must be rigid (rotation + translation); "
                         "give sizes through radius/radii instead of scale")
    return m


def rigid_inverse(m: np.ndarray) -> np.ndarray:
    inv = np.eye(4)
    inv[:3, :3] = m[:3, :3].T
    inv[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return inv


def translation(center) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = np.asarray(center, dtype=np.float64).reshape(3)
    return m


@dataclass(eq=False)
class Collider:
    """A primitive collider; use ``Sphere``, ``Ellipsoid`` or ``Capsule``."""

    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    """local -> world rigid 4x4, metres."""
    mode: str = "projection"
    """'projection' (hard, with friction) or 'penalty' (spring force)."""
    friction: float = 0.2
    """Coulomb coefficient of the projection mode (dimensionless, >= 0)."""
    stiffness: float = 2000.0
    """penalty spring stiffness per unit mass, 1/s^2."""
    margin: float = 0.0
    """extra thickness added to the shape, metres (hair radius, skin offset)."""
    follow_head: bool = False
    """ride on the simulator's head transform."""

    kind = -1

    def __post_init__(self) -> None:
        self.transform = _rigid(self.transform)
        if self.mode not in MODES:
            raise UsageError(f"collider mode must be one of {sorted(MODES)}, got {self.mode!r}")
        for name in ("friction", "stiffness", "margin"):
            v = float(getattr(self, name))
            if not np.isfinite(v) or v < 0:
                raise UsageError(f"collider {name} must be >= 0, got {v}")
            setattr(self, name, v)

    # ---- shape parameters, overridden
    def _radii(self) -> np.ndarray:
        raise NotImplementedError

    def _half_height(self) -> float:
        return 0.0

    def move_to(self, center) -> None:
        """Move the collider's centre (keeps its rotation)."""
        m = self.transform.copy()
        m[:3, 3] = np.asarray(center, dtype=np.float64).reshape(3)
        self.transform = _rigid(m)   # a NaN centre is refused here, not met by every particle

    def world_transform(self, head: np.ndarray | None = None) -> np.ndarray:
        if self.follow_head and head is not None:
            return np.asarray(head, dtype=np.float64) @ self.transform
        return self.transform

    def pack(self, world: np.ndarray, prev_world: np.ndarray) -> np.ndarray:
        """(44,) float32 in the std430 layout of ``collide.glsl``."""
        out = np.zeros(FLOATS_PER_COLLIDER, dtype=np.float32)
        out[0:16] = rigid_inverse(world).T.reshape(-1)  # column-major
        out[16:32] = np.asarray(prev_world).T.reshape(-1)
        out[32:36] = (self.kind, MODES[self.mode], self._half_height(), 0.0)
        out[36:39] = self._radii()
        out[39] = self.margin
        out[40:44] = (self.friction, self.stiffness, 0.0, 0.0)
        return out

    def depth(self, points: np.ndarray, head: np.ndarray | None = None) -> np.ndarray:
        """(n,) penetration depth of world points (metres, > 0 inside, margin included)."""
        world = self.world_transform(head)
        p = (np.asarray(points, dtype=np.float64) - world[:3, 3]) @ world[:3, :3]
        return _local_depth(p, self.kind, self._radii().astype(np.float64) + self.margin,
                            self._half_height())


def _local_depth(p: np.ndarray, kind: int, radii: np.ndarray, half_height: float) -> np.ndarray:
    if kind in (SPHERE, CAPSULE):
        q = np.zeros_like(p)
        if kind == CAPSULE:
            q[:, 1] = np.clip(p[:, 1], -half_height, half_height)
        return radii[0] - np.linalg.norm(p - q, axis=1)
    u = p / radii
    lu = np.linalg.norm(u, axis=1)
    safe = np.where(lu > 1e-12, lu, 1.0)
    s = radii * (u / safe[:, None])
    d = np.linalg.norm(s - p, axis=1)
    return np.where(lu < 1.0, d, -d)


@dataclass(eq=False)
class Sphere(Collider):
    center: tuple = (0.0, 0.0, 0.0)
    """centre, metres (sets ``transform``'s translation)."""
    radius: float = 0.1
    """radius, metres."""

    kind = SPHERE

    def __post_init__(self) -> None:
        if np.allclose(self.transform, np.eye(4)):
            self.transform = translation(self.center)
        super().__post_init__()
        if not np.isfinite(self.radius) or self.radius <= 0:
            raise UsageError(f"sphere radius must be > 0 m, got {self.radius}")

    def _radii(self) -> np.ndarray:
        return np.full(3, self.radius, dtype=np.float32)


@dataclass(eq=False)
class Ellipsoid(Collider):
    center: tuple = (0.0, 0.0, 0.0)
    """centre, metres (sets ``transform``'s translation unless a transform is given)."""
    radii: tuple = (0.1, 0.1, 0.1)
    """semi-axes along the local x, y, z axes, metres."""

    kind = ELLIPSOID

    def __post_init__(self) -> None:
        if np.allclose(self.transform, np.eye(4)):
            self.transform = translation(self.center)
        super().__post_init__()
        r = np.asarray(self.radii, dtype=np.float64).reshape(-1)
        if r.shape != (3,) or not np.all(np.isfinite(r)) or np.any(r <= 0):
            raise UsageError(f"ellipsoid radii must be 3 numbers > 0 m, got {self.radii!r}")
        self.radii = tuple(float(x) for x in r)

    def _radii(self) -> np.ndarray:
        return np.asarray(self.radii, dtype=np.float32)


@dataclass(eq=False)
class Capsule(Collider):
    """A segment from ``a`` to ``b`` swept by a sphere of ``radius`` (local axis: y)."""

    a: tuple = (0.0, -0.05, 0.0)
    """first end of the core segment, metres."""
    b: tuple = (0.0, 0.05, 0.0)
    """second end of the core segment, metres."""
    radius: float = 0.05
    """radius, metres."""

    kind = CAPSULE

    def __post_init__(self) -> None:
        a = np.asarray(self.a, dtype=np.float64).reshape(3)
        b = np.asarray(self.b, dtype=np.float64).reshape(3)
        if np.allclose(self.transform, np.eye(4)):
            self.transform = _frame_along(a, b)
        self._h = 0.5 * float(np.linalg.norm(b - a))
        super().__post_init__()
        if not np.isfinite(self.radius) or self.radius <= 0:
            raise UsageError(f"capsule radius must be > 0 m, got {self.radius}")

    def _radii(self) -> np.ndarray:
        return np.full(3, self.radius, dtype=np.float32)

    def _half_height(self) -> float:
        return self._h


def _frame_along(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rigid frame centred between a and b with its y axis along b - a."""
    d = b - a
    n = np.linalg.norm(d)
    y = d / n if n > 0 else np.array([0.0, 1.0, 0.0])
    helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    x = np.cross(y, helper)
    x /= np.linalg.norm(x)
    z = np.cross(x, y)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, y, z
    m[:3, 3] = 0.5 * (a + b)
    return m


@dataclass(eq=False)
class MeshCollider:
    """A triangle mesh collided through a signed distance field (``mane.sim.sdf.MeshSDF``),
    baked once on first use."""

    mesh: object
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    """local -> world 4x4 of the mesh."""
    resolution: int = 64
    """SDF voxels along the longest axis."""
    padding: float = 0.02
    """extra space around the mesh's bounding box in the SDF, metres."""
    margin: float = 0.002
    """distance kept from the surface, metres."""
    friction: float = 0.2
    """Coulomb-style friction coefficient (dimensionless)."""
    follow_head: bool = True
    """ride on the simulator's head transform (a head mesh does)."""

    _sdf: object = field(default=None, repr=False)

    def world_transform(self, head: np.ndarray | None = None) -> np.ndarray:
        t = np.asarray(self.transform, dtype=np.float64)
        if self.follow_head and head is not None:
            return np.asarray(head, dtype=np.float64) @ t
        return t


HEAD_SDF_RESOLUTION = 48
"""SDF voxels along the longest axis of a head mesh given on the command line."""


def head_collider(mesh) -> MeshCollider:
    """The collider of a head (or body) mesh a user gives (``mane simulate --head``, ``mane
    render --simulate --head``): the mesh itself through its SDF, riding the head's motion."""
    return MeshCollider(mesh, resolution=HEAD_SDF_RESOLUTION, margin=0.002, friction=0.3)


def mesh_distance(mesh, resolution: int = HEAD_SDF_RESOLUTION, padding: float = 0.02):
    """p (M, 3) in the mesh's frame -> (M,) signed distance, metres (negative inside): the
    mesh's SDF baked on the CPU (``mane.sim.sdf.bake_sdf``) and sampled trilinearly, as the
    simulator's shaders do (hybrid interpolation's collider, CPU-side decisions)."""
    from .sdf import bake_sdf, sample_grid

    values, lo, h = bake_sdf(mesh.vertices, mesh.faces, resolution=resolution, padding=padding)
    return lambda p: sample_grid(values, lo, h, np.asarray(p, dtype=np.float64).reshape(-1, 3))


def pack_colliders(colliders, head: np.ndarray, prev_worlds: list | None) -> tuple[np.ndarray, list]:
    """(C*44,) float32 for the primitives, and their world transforms (next ``prev_worlds``)."""
    prims = [c for c in colliders if isinstance(c, Collider)]
    if len(prims) > MAX_COLLIDERS:
        raise UsageError(f"at most {MAX_COLLIDERS} primitive colliders, got {len(prims)}")
    worlds = [c.world_transform(head) for c in prims]
    if prev_worlds is None or len(prev_worlds) != len(worlds):
        prev_worlds = worlds
    data = [c.pack(w, p) for c, w, p in zip(prims, worlds, prev_worlds)]
    out = np.concatenate(data) if data else np.zeros(FLOATS_PER_COLLIDER, np.float32)
    return out, worlds
