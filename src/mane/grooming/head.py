"""The procedural default head: a bust (head, neck, shoulders) made by code, with a painted scalp.

The shape is a signed distance field: ellipsoids, capsules and spheres joined with smooth
minima (cranium, face, jaw, chin, brow, cheekbones, nose, lips, eye sockets, ears, neck,
trapezius, deltoids, chest), cut flat below the chest. The mesh is an icosphere whose every
vertex is sent along a ray, from a centre that slides down the body's axis, to the first point
where the field crosses zero; a few rounds of Laplacian relaxation, each followed by a Newton
projection back onto the surface, even out the triangles. Because the mesh keeps the sphere's
connectivity it is closed, manifold and wound counter-clockwise seen from outside.

Frame: metres, Y up, right-handed, the face looks toward +Z; the origin lies at the centre of
the head (about at the height of the eyes, midway between the ears). The head is about 0.235 m
from chin to crown and the shoulders about 0.46 m across.

The scalp is painted into the vertex colours: ``colors[:, 0]`` (red) is the scalp weight in
[0, 1] with a soft, natural hairline (forehead, temples, sideburns in front of the ears, above
the ears, down to the nape); green and blue hold a skin tone scaled by ``1 - weight`` so that a
renderer that draws vertex colours shows the scalp. The same weight is kept as
``vertex_attributes['scalp']``.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import GroomError
from ..mesh import Mesh

HEAD_CENTER = np.array([0.0, 0.0, 0.0])
"""The head's centre (m): the origin, midway between the ears at about eye height."""

SCALP_CHANNEL = 0
"""The vertex-colour channel (red) that holds the scalp weight."""

SKIN_TONE = np.array([0.80, 0.62, 0.52])

# ---------------------------------------------------------------------------- SDF primitives


def _ellipsoid(p: np.ndarray, c, r) -> np.ndarray:
    """Approximate signed distance to an axis-aligned ellipsoid (exact zero set)."""
    r = np.asarray(r, dtype=np.float64)
    q = (p - np.asarray(c, dtype=np.float64)) / r
    k0 = np.linalg.norm(q, axis=-1)
    k1 = np.linalg.norm(q / r, axis=-1)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _sphere(p, c, r):
    return np.linalg.norm(p - np.asarray(c, dtype=np.float64), axis=-1) - r


def _capsule(p, a, b, r):
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    pa, ba = p - a, b - a
    h = np.clip((pa @ ba) / (ba @ ba), 0.0, 1.0)
    return np.linalg.norm(pa - h[..., None] * ba, axis=-1) - r


def _smin(a, b, k):
    """Polynomial smooth minimum (a union with a fillet of size ~k)."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def _smax(a, b, k):
    return -_smin(-a, -b, k)


def _mirror(p):
    """The point with |x|: features defined on the +X side apply to both sides."""
    q = p.copy()
    q[..., 0] = np.abs(q[..., 0])
    return q


def head_sdf(p: np.ndarray) -> np.ndarray:
    """Signed distance-like field of the default bust (negative inside), for (..., 3) points."""
    p = np.asarray(p, dtype=np.float64)
    m = _mirror(p)
    # skull and face
    d = _ellipsoid(p, (0.0, 0.028, -0.016), (0.075, 0.084, 0.097))  # cranium
    d = _smin(d, _ellipsoid(p, (0.0, -0.032, 0.030), (0.060, 0.086, 0.066)), 0.025)  # face
    d = _smin(d, _ellipsoid(p, (0.0, -0.068, 0.012), (0.057, 0.050, 0.066)), 0.02)  # jaw
    d = _smin(d, _ellipsoid(p, (0.0, -0.108, 0.062), (0.020, 0.016, 0.018)), 0.018)  # chin
    d = _smin(d, _ellipsoid(m, (0.045, -0.014, 0.058), (0.024, 0.017, 0.024)), 0.02)  # cheekbones
    d = _smin(d, _ellipsoid(p, (0.0, 0.020, 0.078), (0.052, 0.014, 0.020)), 0.02)  # brow
    # eye sockets, then eyeballs inside them
    d = _smax(d, -_sphere(m, (0.031, 0.000, 0.103), 0.0160), 0.012)
    d = _smin(d, _sphere(m, (0.031, 0.000, 0.083), 0.0120), 0.006)
    # nose: bridge, tip, wings
    d = _smin(d, _capsule(p, (0.0, 0.006, 0.094), (0.0, -0.031, 0.112), 0.0085), 0.012)
    d = _smin(d, _sphere(p, (0.0, -0.033, 0.109), 0.0110), 0.008)
    d = _smin(d, _ellipsoid(m, (0.010, -0.039, 0.099), (0.0100, 0.0080, 0.0100)), 0.008)
    # mouth: a soft muzzle
    d = _smin(d, _ellipsoid(p, (0.0, -0.066, 0.080), (0.026, 0.017, 0.014)), 0.012)
    # ears
    d = _smin(d, _ellipsoid(m, (0.077, -0.010, -0.016), (0.011, 0.031, 0.019)), 0.008)
    # neck, shoulders, chest
    d = _smin(d, _capsule(p, (0.0, -0.06, -0.024), (0.0, -0.22, -0.034), 0.057), 0.025)
    body = _capsule(m, (0.0, -0.165, -0.050), (0.160, -0.212, -0.038), 0.048)  # trapezius
    body = _smin(body, _ellipsoid(m, (0.168, -0.238, -0.032), (0.050, 0.058, 0.054)), 0.05)  # deltoids
    body = _smin(body, _ellipsoid(p, (0.0, -0.345, -0.030), (0.178, 0.170, 0.098)), 0.06)  # chest
    d = _smin(d, body, 0.035)
    d = _smax(d, -(p[..., 1] + 0.46), 0.01)  # flat base
    return d


def _sdf_gradient(p: np.ndarray, h: float = 1e-5, f0: np.ndarray | None = None) -> np.ndarray:
    """Forward-difference gradient of the field."""
    f0 = head_sdf(p) if f0 is None else f0
    g = np.empty_like(p)
    for k in range(3):
        q = p.copy()
        q[:, k] += h
        g[:, k] = (head_sdf(q) - f0) / h
    return g


# ---------------------------------------------------------------------------- meshing

# Stages of the ray parameter u (degrees, 0 at the crown, 180 under the base): the head seen
# from its centre, the jaw and neck from a centre sliding down to the chest, the base.
_C_HEAD = np.array([0.0, 0.0, 0.0])
_C_JAW = np.array([0.0, -0.14, -0.02])
_C_CHEST = np.array([0.0, -0.34, -0.028])
_U_A, _U_B, _U_C = 100.0, 112.0, 150.0
_ALPHA_A = 140.0  # the head stage's last ray angle from +Y, degrees
_HEAD_DENSITY = 5.0  # relative vertex density on the head against the body


def _rays(u: np.ndarray, xz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray origins and directions for stage parameters ``u`` and unit azimuth vectors ``xz``."""
    alpha = np.empty_like(u)
    origin = np.empty((len(u), 3))
    s = u <= _U_A
    alpha[s] = u[s] * (_ALPHA_A / _U_A)
    origin[s] = _C_HEAD
    s = (u > _U_A) & (u <= _U_B)
    w = ((u[s] - _U_A) / (_U_B - _U_A))[:, None]
    alpha[s] = _ALPHA_A + (90.0 - _ALPHA_A) * w[:, 0]
    origin[s] = _C_HEAD + (_C_JAW - _C_HEAD) * w
    s = (u > _U_B) & (u <= _U_C)
    w = ((u[s] - _U_B) / (_U_C - _U_B))[:, None]
    alpha[s] = 90.0
    origin[s] = _C_JAW + (_C_CHEST - _C_JAW) * w
    s = u > _U_C
    alpha[s] = 90.0 + 90.0 * (u[s] - _U_C) / (180.0 - _U_C)
    origin[s] = _C_CHEST
    a = np.radians(alpha)
    direction = np.stack([np.sin(a) * xz[:, 0], np.cos(a), np.sin(a) * xz[:, 1]], axis=1)
    return origin, direction


def _surface(u: np.ndarray, xz: np.ndarray) -> np.ndarray:
    origin, direction = _rays(u, xz)
    return origin + _first_exit(origin, direction)[:, None] * direction


def _area_map(n_u: int = 181, n_az: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative (density-weighted) surface area fraction against the stage parameter u."""
    u = np.linspace(0.0, 180.0, n_u)
    az = np.linspace(0.0, 2 * np.pi, n_az, endpoint=False)
    xz = np.stack([np.sin(az), np.cos(az)], axis=1)
    uu = np.repeat(u, n_az)
    pts = _surface(uu, np.tile(xz, (n_u, 1))).reshape(n_u, n_az, 3)
    circ = np.linalg.norm(pts - np.roll(pts, -1, axis=1), axis=2).sum(axis=1)
    ds = np.linalg.norm(pts[1:] - pts[:-1], axis=2).mean(axis=1)
    dens = np.where(u[:-1] < _U_A, _HEAD_DENSITY, 1.0)
    band = 0.5 * (circ[:-1] + circ[1:]) * ds * dens
    cum = np.concatenate([[0.0], np.cumsum(band)])
    return u, cum / cum[-1]


def _first_exit(origin: np.ndarray, direction: np.ndarray, t_max=0.6, step=0.003) -> np.ndarray:
    """Distance along each ray to the first inside-to-outside crossing of the field."""
    n = len(origin)
    hi = np.full(n, np.nan)
    t = 0.0
    while t < t_max:
        idx = np.flatnonzero(np.isnan(hi))
        if idx.size == 0:
            break
        t += step
        f = head_sdf(origin[idx] + t * direction[idx])
        hi[idx[f > 0]] = t
    if np.isnan(hi).any():
        raise GroomError("internal: a head ray never left the body")
    lo = hi - step
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        inside = head_sdf(origin + mid[:, None] * direction) <= 0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return 0.5 * (lo + hi)


def _project(v: np.ndarray, rounds: int = 2) -> np.ndarray:
    """Newton steps onto the zero set of the field."""
    for _ in range(rounds):
        f = head_sdf(v)
        g = _sdf_gradient(v, f0=f)
        v = v - (f / np.maximum((g * g).sum(axis=1), 1e-12))[:, None] * g
    return v


def _relax(v: np.ndarray, faces: np.ndarray, rounds: int, strength: float = 0.6) -> np.ndarray:
    """Tangential Laplacian smoothing, each round projected back onto the surface."""
    n = len(v)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    deg = np.bincount(edges[:, 0], minlength=n).astype(np.float64)
    # The face keeps its ray-cast vertices: relaxing would round the nose off.
    keep = 1.0 - _smoothstep(0.045, 0.07, v[:, 2]) * _smoothstep(-0.085, -0.065, v[:, 1])
    for _ in range(rounds):
        acc = np.zeros_like(v)
        np.add.at(acc, edges[:, 0], v[edges[:, 1]])
        lap = acc / deg[:, None] - v
        f = head_sdf(v)
        g = _sdf_gradient(v, f0=f)
        g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
        lap -= (lap * g).sum(axis=1, keepdims=True) * g  # keep only the tangential part
        v = _project(v + (strength * keep)[:, None] * lap, rounds=1)
    return _project(v, rounds=2)


# ---------------------------------------------------------------------------- scalp paint


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


# Hairline height (m, head frame) against the azimuth around Y from the face (+Z), degrees.
# Forehead, temples (receding a little), sideburns in front of the ear, above the ear, behind
# the ear, nape.
_HAIRLINE_AZ = np.array([0.0, 25.0, 45.0, 60.0, 70.0, 78.0, 85.0, 91.0, 104.0, 116.0, 125.0, 150.0, 180.0])
_HAIRLINE_Y = np.array([0.072, 0.068, 0.060, 0.050, 0.032, -0.030, -0.030, 0.026, 0.030, 0.024,
                        -0.045, -0.085, -0.092])
_HAIRLINE_SOFTNESS = 0.010  # m, width of the soft edge


def scalp_weight(points: np.ndarray) -> np.ndarray:
    """(N,) scalp weight in [0, 1] of points on the default head (head frame, metres)."""
    p = np.asarray(points, dtype=np.float64) - HEAD_CENTER
    az = np.degrees(np.abs(np.arctan2(p[:, 0], p[:, 2])))  # 0 front, 180 back, both sides
    line = np.interp(az, _HAIRLINE_AZ, _HAIRLINE_Y)
    w = _smoothstep(line - 0.5 * _HAIRLINE_SOFTNESS, line + 0.5 * _HAIRLINE_SOFTNESS, p[:, 1])
    # not the ears themselves, nor anything below the skull
    ear = _ellipsoid(_mirror(p), (0.077, -0.010, -0.014), (0.016, 0.036, 0.024))
    w *= _smoothstep(-0.002, 0.004, ear)
    return w


# ---------------------------------------------------------------------------- public


@lru_cache(maxsize=4)
def _build(subdivisions: int, relax_rounds: int) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    unit = np.asarray(sphere.vertices, dtype=np.float64)
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    faces = np.asarray(sphere.faces, dtype=np.int64)
    # Equal sphere area -> equal (density-weighted) bust area, ring by ring.
    u_grid, frac = _area_map()
    sphere_frac = 0.5 * (1.0 - np.clip(unit[:, 1], -1.0, 1.0))
    u = np.interp(sphere_frac, frac, u_grid)
    xz = unit[:, [0, 2]]
    xz = xz / np.maximum(np.linalg.norm(xz, axis=1, keepdims=True), 1e-12)
    v = _surface(u, xz)
    v = _relax(v, faces, relax_rounds)
    return v, faces


def default_head(subdivisions: int = 5, relax_rounds: int = 25) -> Mesh:
    """The procedural bust as a Mesh (cached; each call returns a fresh Mesh of shared data).

    ``subdivisions`` of the underlying icosphere: 5 gives 20,480 triangles. The scalp weight is
    in ``colors[:, 0]`` and ``vertex_attributes['scalp']``.
    """
    v, faces = _build(int(subdivisions), int(relax_rounds))
    weight = scalp_weight(v)
    colors = np.empty((len(v), 4), dtype=np.float32)
    colors[:, 0] = weight
    colors[:, 1:3] = (SKIN_TONE[1:3][None, :] * (1.0 - weight[:, None]))
    colors[:, 3] = 1.0
    mesh = Mesh(
        v.astype(np.float32),
        faces.astype(np.int32),
        colors=colors,
        vertex_attributes={"scalp": weight.astype(np.float32)},
        metadata={"source": "mane.grooming.head.default_head", "subdivisions": int(subdivisions),
                  "scalp_channel": SCALP_CHANNEL},
    )
    return mesh


def scalp_mask(mesh: Mesh, threshold: float = 0.5, channel: int = SCALP_CHANNEL) -> np.ndarray:
    """(V,) bool: vertices whose colour ``channel`` is at least ``threshold``."""
    if mesh.colors is None:
        raise GroomError("the mesh has no vertex colours, so it has no painted scalp")
    if not 0 <= channel < mesh.colors.shape[1]:
        raise GroomError(f"colour channel {channel} out of range 0..{mesh.colors.shape[1] - 1}")
    return mesh.colors[:, channel] >= threshold


def scalp_faces(mesh: Mesh, threshold: float = 0.5, channel: int = SCALP_CHANNEL) -> np.ndarray:
    """(F,) bool: faces whose mean scalp weight (colour ``channel``) is at least ``threshold``."""
    if mesh.colors is None:
        raise GroomError("the mesh has no vertex colours, so it has no painted scalp")
    w = mesh.colors[:, channel].astype(np.float64)[mesh.faces].mean(axis=1)
    return w >= threshold


__all__ = ["default_head", "head_sdf", "scalp_weight", "scalp_mask", "scalp_faces",
           "HEAD_CENTER", "SCALP_CHANNEL"]
