"""The procedural default head: a bust (head, neck, shoulders) made by code, with a painted scalp.

The shape is a signed distance field: ellipsoids, capsules and spheres joined with smooth
minima: cranium, forehead, midface, a jaw line tapering to the chin, cheekbones, cheeks, brow
ridge, eye sockets with eyeballs and upper lids, the nose's bridge, tip and wings, a muzzle
with upper and lower lips, ears with a hollow, a neck with its sternocleidomastoids,
collarbones, trapezius, deltoids and chest, cut flat below the chest. The mesh is an icosphere
(built here) whose every vertex is sent along a ray, from a centre that slides down the body's
axis, to the first point where the field crosses zero (sphere tracing, then bisection); a few
rounds of tangential Laplacian relaxation, each followed by a Newton step back onto the
surface, even out the triangles (the face keeps its ray-cast vertices, which hold the nose).
Because the mesh keeps the sphere's connectivity it is closed, manifold and wound
counter-clockwise seen from outside. Shading normals come from the field's gradient. A built
bust is cached on disk (``~/.cache/mane``, keyed by a hash of this file; ``MANE_NO_CACHE=1``
turns it off): the first build takes seconds, later ones a fraction of a second.

Frame: metres, Y up, right-handed, the face looks toward +Z; the origin lies at the centre of
the head (at the height of the eyes, midway between the ears). Head breadth 14.8 cm, length
(brow to back) 20.4 cm, chin to vertex 23.2 cm, shoulders about 0.42 m across.

The scalp is painted into the vertex colours: ``colors[:, 0]`` (red) is the scalp weight in
[0, 1] with a soft, natural hairline (forehead 4.6 cm above the brow, temples, sideburns in
front of the ears, above the ears, down to the nape; about 620 cm² of scalp); green and blue
hold a skin tone scaled by ``1 - weight`` so that a renderer that draws vertex colours shows
the scalp. The same weight is kept as ``vertex_attributes['scalp']``. ``FACE_BOX`` is the
space in front of the eyes, nose and mouth that grown hair keeps out of.
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

FACE_BOX = ((-0.048, -0.115, 0.045), (0.048, 0.045, 0.25))
"""(lo, hi) metres: the space in front of the eyes, nose and mouth that hair must not cross."""

# ---------------------------------------------------------------------------- SDF primitives


def _norm(q: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...k,...k->...", q, q))


def _ellipsoid(p: np.ndarray, c, r) -> np.ndarray:
    """Approximate signed distance to an axis-aligned ellipsoid (exact zero set)."""
    r = np.asarray(r, dtype=np.float64)
    q = (p - np.asarray(c, dtype=np.float64)) / r
    k0 = _norm(q)
    k1 = _norm(q / r)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _sphere(p, c, r):
    return _norm(p - np.asarray(c, dtype=np.float64)) - r


def _capsule(p, a, b, r):
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    pa, ba = p - a, b - a
    h = np.clip((pa @ ba) / (ba @ ba), 0.0, 1.0)
    return _norm(pa - h[..., None] * ba) - r


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
    # cranium, forehead and the back of the skull
    d = _ellipsoid(p, (0.0, 0.030, -0.014), (0.074, 0.083, 0.095))
    d = _smin(d, _ellipsoid(p, (0.0, 0.035, 0.030), (0.066, 0.062, 0.060)), 0.02)      # forehead
    # face: midface and the mandible (a tapered jaw, its angles and the chin)
    d = _smin(d, _ellipsoid(p, (0.0, -0.030, 0.028), (0.058, 0.070, 0.062)), 0.02)     # midface
    d = _smin(d, _capsule(m, (0.052, -0.052, -0.008), (0.020, -0.098, 0.056), 0.013), 0.026)  # jaw line
    d = _smin(d, _ellipsoid(p, (0.0, -0.097, 0.062), (0.022, 0.020, 0.017)), 0.020)    # chin
    d = _smin(d, _ellipsoid(m, (0.042, -0.012, 0.060), (0.022, 0.016, 0.022)), 0.018)  # cheekbones
    d = _smin(d, _ellipsoid(m, (0.036, -0.048, 0.052), (0.026, 0.028, 0.024)), 0.02)  # cheeks
    d = _smin(d, _capsule(m, (0.014, 0.022, 0.084), (0.046, 0.024, 0.068), 0.0095), 0.012)  # brow ridge
    # eye sockets, eyeballs, upper lids
    d = _smax(d, -_ellipsoid(m, (0.032, 0.003, 0.090), (0.018, 0.012, 0.010)), 0.008)
    d = _smin(d, _sphere(m, (0.032, 0.000, 0.070), 0.0120), 0.004)
    d = _smin(d, _ellipsoid(m, (0.032, 0.0050, 0.074), (0.0130, 0.0070, 0.0090)), 0.005)  # upper lid
    # nose: body, bridge, tip, wings (alae) blended into one
    d = _smin(d, _ellipsoid(p, (0.0, -0.020, 0.090), (0.012, 0.022, 0.013)), 0.012)
    d = _smin(d, _capsule(p, (0.0, 0.012, 0.087), (0.0, -0.026, 0.108), 0.0062), 0.012)
    d = _smin(d, _sphere(p, (0.0, -0.029, 0.105), 0.0090), 0.010)
    d = _smin(d, _ellipsoid(m, (0.0095, -0.033, 0.095), (0.0065, 0.0055, 0.0070)), 0.010)
    # mouth: the muzzle under the nose, upper and lower lips
    d = _smin(d, _ellipsoid(p, (0.0, -0.058, 0.074), (0.028, 0.024, 0.020)), 0.012)
    d = _smin(d, _ellipsoid(p, (0.0, -0.0580, 0.0880), (0.0230, 0.0075, 0.0100)), 0.010)  # upper lip
    d = _smin(d, _ellipsoid(p, (0.0, -0.0710, 0.0860), (0.0200, 0.0080, 0.0100)), 0.010)  # lower lip
    # ears: a flat shell leaning back, with a hollow (concha)
    ear = _ellipsoid(m, (0.074, -0.012, -0.012), (0.012, 0.030, 0.018))
    ear = _smax(ear, -_ellipsoid(m, (0.086, -0.016, -0.008), (0.006, 0.016, 0.009)), 0.003)
    d = _smin(d, ear, 0.006)
    # neck with its sternocleidomastoids, then shoulders and chest
    d = _smin(d, _capsule(p, (0.0, -0.050, -0.024), (0.0, -0.200, -0.010), 0.052), 0.04)
    d = _smin(d, _capsule(m, (0.045, -0.060, -0.030), (0.014, -0.205, 0.030), 0.012), 0.02)
    body = _capsule(m, (0.030, -0.175, -0.030), (0.150, -0.220, -0.035), 0.040)  # trapezius
    body = _smin(body, _ellipsoid(m, (0.165, -0.255, -0.030), (0.045, 0.060, 0.050)), 0.04)  # deltoids
    body = _smin(body, _ellipsoid(p, (0.0, -0.330, -0.025), (0.160, 0.125, 0.090)), 0.05)  # chest
    body = _smin(body, _capsule(m, (0.012, -0.215, 0.030), (0.120, -0.215, 0.010), 0.010), 0.02)  # collarbones
    d = _smin(d, body, 0.03)
    d = _smax(d, -(p[..., 1] + 0.40), 0.01)  # flat base
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
_C_JAW = np.array([0.0, -0.13, 0.0])
_C_CHEST = np.array([0.0, -0.34, -0.028])
_U_A, _U_B, _U_C = 100.0, 112.0, 150.0
_ALPHA_A = 150.0  # the head stage's last ray angle from +Y, degrees
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


def _first_exit(origin: np.ndarray, direction: np.ndarray, t_max=0.6) -> np.ndarray:
    """Distance along each ray to the first inside-to-outside crossing of the field.

    Sphere tracing from the inside: while the field is negative, a step of 0.8 |f| (at least
    0.4 mm) cannot jump over the surface of a field whose slope is at most about one; the last
    step is then bisected.
    """
    n = len(origin)
    t = np.zeros(n)
    prev = np.zeros(n)
    live = np.arange(n)
    while live.size:
        f = head_sdf(origin[live] + t[live, None] * direction[live])
        inside = live[f <= 0]
        prev[inside] = t[inside]
        t[inside] += np.maximum(0.8 * -f[f <= 0], 4e-4)
        if (t[inside] >= t_max).any():
            raise GroomError("internal: a head ray never left the body")
        live = inside
    lo, hi = prev, t
    for _ in range(12):
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


def _relax(v: np.ndarray, faces: np.ndarray, rounds: int, strength: float = 0.6,
           hold_face: float = 1.0) -> np.ndarray:
    """Tangential Laplacian smoothing, each round followed by a Newton step back onto the
    surface (with the round's gradient). ``hold_face`` (0..1): how firmly the face keeps its
    ray-cast vertices (1: fixed, which keeps the nose sharp on a fine mesh; a coarse mesh is
    better relaxed, its few face vertices zigzag otherwise)."""
    n = len(v)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    deg = np.bincount(edges[:, 0], minlength=n).astype(np.float64)
    keep = 1.0 - hold_face * _smoothstep(0.040, 0.065, v[:, 2]) * _smoothstep(-0.125, -0.100, v[:, 1])
    for _ in range(rounds):
        acc = np.zeros_like(v)
        np.add.at(acc, edges[:, 0], v[edges[:, 1]])
        lap = acc / deg[:, None] - v
        f = head_sdf(v)
        g = _sdf_gradient(v, f0=f)
        gn = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
        lap -= (lap * gn).sum(axis=1, keepdims=True) * gn  # keep only the tangential part
        v = v + (strength * keep)[:, None] * lap
        f = head_sdf(v)
        v = v - (f / np.maximum((g * g).sum(axis=1), 1e-12))[:, None] * g
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
    ear = _ellipsoid(_mirror(p), (0.076, -0.012, -0.012), (0.016, 0.034, 0.022))
    w *= _smoothstep(-0.002, 0.004, ear)
    return w


# ---------------------------------------------------------------------------- public


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere: (V, 3) float64 vertices and (F, 3) int64 faces, counter-clockwise seen
    from outside; every subdivision splits each triangle in four at its edges' midpoints."""
    g = (1.0 + 5.0 ** 0.5) / 2.0
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
                  [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(int(subdivisions)):
        e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        uniq, inv = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True)
        mid = v[uniq].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(v) + inv.reshape(3, -1).T  # (F, 3): midpoints of edges 01, 12, 20
        v = np.concatenate([v, mid])
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        f = np.concatenate([np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([b, m[:, 1], m[:, 0]], 1),
                            np.stack([c, m[:, 2], m[:, 1]], 1), m])
    return v, f


def _cache_file(subdivisions: int, relax_rounds: int):
    """Where a built bust is kept between runs (None when caching is off: MANE_NO_CACHE=1).
    The name carries a hash of this file, so any change to the shape builds afresh."""
    import hashlib
    import os
    from pathlib import Path

    if os.environ.get("MANE_NO_CACHE"):
        return None
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mane"
    digest = hashlib.sha1(Path(__file__).read_bytes()).hexdigest()[:12]
    return root / f"default_head_{digest}_{subdivisions}_{relax_rounds}.npz"


@lru_cache(maxsize=4)
def _build(subdivisions: int, relax_rounds: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bust's vertices, faces and normals: from the on-disk cache, or built (seconds) and
    cached (then a fraction of a second)."""
    import os

    path = _cache_file(subdivisions, relax_rounds)
    if path is not None and path.is_file():
        try:
            with np.load(path) as z:
                return z["vertices"], z["faces"], z["normals"]
        except (OSError, KeyError, ValueError):
            pass  # a damaged cache file: build afresh
    built = _build_uncached(subdivisions, relax_rounds)
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
            np.savez(tmp, vertices=built[0], faces=built[1], normals=built[2])
            os.replace(tmp, path)
        except OSError:
            pass  # a read-only home: build every time
    return built


def _build_uncached(subdivisions: int, relax_rounds: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if not 0 <= subdivisions <= 7:
        raise GroomError(f"head subdivisions must be in 0..7, got {subdivisions}")
    unit, faces = icosphere(subdivisions)
    # Equal sphere area -> equal (density-weighted) bust area, ring by ring.
    u_grid, frac = _area_map()
    sphere_frac = 0.5 * (1.0 - np.clip(unit[:, 1], -1.0, 1.0))
    u = np.interp(sphere_frac, frac, u_grid)
    xz = unit[:, [0, 2]]
    xz = xz / np.maximum(np.linalg.norm(xz, axis=1, keepdims=True), 1e-12)
    v = _surface(u, xz)
    v = _relax(v, faces, relax_rounds, hold_face=1.0 if subdivisions >= 5 else 0.0)
    # shading normals from the field (smooth where the triangles are long and thin)
    g = _sdf_gradient(v, h=2e-4)
    normals = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
    return v, faces, normals


def default_head(subdivisions: int = 5, relax_rounds: int = 12) -> Mesh:
    """The procedural bust as a Mesh (cached; each call returns a fresh Mesh of shared data).

    ``subdivisions`` of the underlying icosphere: 5 gives 20,480 triangles. The scalp weight is
    in ``colors[:, 0]`` and ``vertex_attributes['scalp']``.
    """
    v, faces, normals = _build(int(subdivisions), int(relax_rounds))
    weight = scalp_weight(v)
    colors = np.empty((len(v), 4), dtype=np.float32)
    colors[:, 0] = weight
    colors[:, 1:3] = (SKIN_TONE[1:3][None, :] * (1.0 - weight[:, None]))
    colors[:, 3] = 1.0
    mesh = Mesh(
        v.astype(np.float32),
        faces.astype(np.int32),
        normals=normals.astype(np.float32),
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
           "HEAD_CENTER", "SCALP_CHANNEL", "FACE_BOX"]
