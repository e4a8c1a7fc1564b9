"""Procedural hair styles grown from follicles: straight, wavy and curly, with droop and clumps.

A strand is grown in three layers, all vectorised over strands (the only loops run along the
points of a strand):

1. The centreline starts at the follicle along the surface normal; at every step gravity bends
   the direction toward ``gravity`` by ``droop × step / droop_length`` (so it turns down over
   about ``droop_length`` of hair), and a point that would enter the mesh is pushed out along
   the nearest surface normal, so hair on the crown lies on the scalp and falls off its sides.
2. Waves and curls are offsets in a frame parallel-transported along the centreline: a planar
   sine (``wave_amplitude``, ``wave_length``) or a helix (``curl_radius``, ``curl_pitch``)
   around the centreline, faded in over ``curl_start`` from the root.
3. Clumps: follicles are gathered around clump centres about ``clump_radius`` apart; a clump
   waves or curls as one lock (its strands take the centre strand's phase and side), and every
   point is pulled toward the same point of its clump's centre strand by
   ``clump_strength × (t ** clump_taper)``, t being 0 at the root and 1 at the tip.

With a ``parting`` the root direction is combed away from the parting line, back over the
front and down behind the crown (``parted_comb``), and a strand that would cross ``face_box``
(in front of the eyes, nose and mouth) ends just before it: hair frames the face.

A last pass pushes every point but the roots out of the mesh again.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from ..errors import UsageError
from ..groom import Groom
from ..mesh import Mesh
from .collider import SurfaceProximity
from .follicles import Follicles, VertexColorRegion, sample_follicles

KINDS = ("straight", "wavy", "curly")


@dataclass(frozen=True)
class StyleSettings:
    """How a procedural style grows. Lengths in metres, angles in radians."""

    kind: str = "straight"
    """'straight', 'wavy' or 'curly'."""
    length: float = 0.22
    """Mean strand length (m): arc length along the hair, curls included."""
    length_variation: float = 0.15
    """Relative standard deviation of strand lengths (0: all the same)."""
    droop: float = 1.0
    """Strength of gravity's bend (0: hair grows straight along the surface normal)."""
    droop_length: float = 0.03
    """Length of hair (m) over which gravity turns the growth direction down, for droop 1."""
    direction_jitter: float = 0.12
    """Random tilt of the initial direction away from the normal (radians)."""
    sweep: float = 0.8
    """How strongly hair is combed along ``sweep_direction`` at the root (0: along the normal)."""
    sweep_direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    """Combing direction (unit; projected onto the surface): by default back, off the face.
    Used when ``parting`` is None."""
    parting: float | None = None
    """X (m, head frame: Y up, face toward +Z) of a parting line over the top of the head, or
    None. With a parting, hair is combed away from it, sideways and back over the top, back and
    down behind the crown, and back past the ears on the sides: off the face."""
    fringe: bool = False
    """With a parting: hair rooted over the forehead is combed forward and down instead, as a
    fringe (bangs), which ``face_box`` cuts off above the eyes."""
    face_box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    """An (lo, hi) box in front of the face (eyes, nose, mouth) that no hair may cross: a strand
    that would enter it is cut ``face_clearance`` before it does (a fringe that stops above the
    eyes). None: the default head's box when growing on the default head, else no box."""
    face_clearance: float = 0.01
    """How far (m of strand) before the face box a strand that would cross it ends."""
    wave_amplitude: float = 0.008
    """Wavy: half the peak-to-peak sideways excursion (m)."""
    wave_length: float = 0.06
    """Wavy: length of one wave along the strand (m)."""
    curl_radius: float = 0.006
    """Curly: radius of the helix (m)."""
    curl_pitch: float = 0.02
    """Curly: rise of the helix per turn along its axis (m)."""
    curl_start: float = 0.015
    """Waves and curls fade in over this length from the root (m)."""
    clump_radius: float = 0.012
    """Spacing of clump centres (m); 0 for no clumps."""
    clump_strength: float = 0.35
    """How far tips are pulled toward their clump's centre strand (0..1)."""
    clump_taper: float = 1.5
    """Exponent of the clump pull along the strand (higher: only near the tip)."""
    root_width: float = 70e-6
    """Strand diameter at the root (m)."""
    tip_width_ratio: float = 0.25
    """Diameter at the tip as a fraction of the root's."""
    color: tuple[float, float, float] | None = (0.23, 0.14, 0.08)
    """Linear RGB of the hair, or None for no colours."""
    color_variation: float = 0.08
    """Relative per-strand variation of the colour."""
    collision_margin: float = 0.0015
    """Clearance (m) kept between hair points and the mesh."""
    gravity: tuple[float, float, float] = (0.0, -1.0, 0.0)
    """Unit direction that droop bends hair toward."""

    def validate(self) -> "StyleSettings":
        if self.kind not in KINDS:
            raise UsageError(f"unknown style kind {self.kind!r}; use one of {', '.join(KINDS)}")
        positive = ("length", "droop_length", "wave_length", "curl_pitch", "root_width")
        for name in positive:
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise UsageError(f"style {name} must be a positive number of metres, got {v}")
        non_negative = ("length_variation", "droop", "direction_jitter", "sweep", "wave_amplitude",
                        "curl_radius", "curl_start", "clump_radius", "clump_strength",
                        "clump_taper", "tip_width_ratio", "color_variation", "collision_margin")
        for name in non_negative:
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise UsageError(f"style {name} must be zero or positive, got {v}")
        if self.parting is not None and not np.isfinite(self.parting):
            raise UsageError(f"parting must be a number of metres or None, got {self.parting}")
        if self.clump_strength > 1:
            raise UsageError(f"clump_strength must be in 0..1, got {self.clump_strength}")
        return self


# Every preset is parted a little off the middle and combed off the face (see ``parted_comb``).
_PARTED = dict(parting=0.022, sweep=2.5, droop_length=0.05)
PRESETS: dict[str, StyleSettings] = {
    "straight": StyleSettings(kind="straight", **_PARTED),
    "wavy": StyleSettings(kind="wavy", length=0.25, wave_amplitude=0.008, wave_length=0.06, **_PARTED),
    "curly": StyleSettings(kind="curly", length=0.30, curl_radius=0.007, curl_pitch=0.02,
                           droop=0.6, clump_strength=0.2, **{**_PARTED, "parting": 0.0}),
    "short": StyleSettings(kind="straight", length=0.05, droop=0.4, clump_strength=0.1, **_PARTED),
    "long": StyleSettings(kind="straight", length=0.45, length_variation=0.1, clump_strength=0.45, **_PARTED),
    "bob": StyleSettings(kind="straight", length=0.16, length_variation=0.08,
                         clump_strength=0.3, fringe=True, **{**_PARTED, "parting": 0.0, "droop_length": 0.04}),
    "long_wavy": StyleSettings(kind="wavy", length=0.26, length_variation=0.1, wave_amplitude=0.009,
                               wave_length=0.09, clump_radius=0.015, clump_strength=0.35, **_PARTED),
}


def style_settings(style: str | StyleSettings = "straight", **overrides) -> StyleSettings:
    """A preset by name (or settings as given) with some fields replaced; validated."""
    if isinstance(style, StyleSettings):
        base = style
    else:
        try:
            base = PRESETS[str(style)]
        except KeyError:
            raise UsageError(f"unknown style {style!r}; presets: {', '.join(PRESETS)}") from None
    names = {f.name for f in fields(StyleSettings)}
    unknown = set(overrides) - names
    if unknown:
        raise UsageError(f"unknown style settings: {', '.join(sorted(unknown))}")
    return replace(base, **{k: v for k, v in overrides.items() if v is not None}).validate()


# ---------------------------------------------------------------------------- geometry helpers


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-30)


def _rotate_min(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotate vectors x by the smallest rotation taking unit a to unit b (row-wise)."""
    v = np.cross(a, b)
    c = (a * b).sum(axis=-1, keepdims=True)
    k = 1.0 / np.maximum(1.0 + c, 1e-9)
    return x * c + np.cross(v, x) + v * ((v * x).sum(axis=-1, keepdims=True) * k)


def _smoothstep01(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _tangents(p: np.ndarray) -> np.ndarray:
    """(S, N, 3) unit tangents of (S, N, 3) polylines (central differences inside)."""
    t = np.empty_like(p)
    t[:, 1:-1] = p[:, 2:] - p[:, :-2]
    t[:, 0] = p[:, 1] - p[:, 0]
    t[:, -1] = p[:, -1] - p[:, -2]
    return _normalize(t)


def transported_frames(p: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tangent, u, v (S, N, 3) along polylines: ``ref`` (S, 3) at the root, parallel-transported."""
    T = _tangents(p)
    u = np.empty_like(p)
    u0 = ref - (ref * T[:, 0]).sum(axis=1, keepdims=True) * T[:, 0]
    bad = np.linalg.norm(u0, axis=1) < 1e-6
    if bad.any():  # ref along the tangent: any perpendicular will do
        alt = np.where(np.abs(T[bad, 0, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
        u0[bad] = np.cross(T[bad, 0], alt)
    u[:, 0] = _normalize(u0)
    for i in range(1, p.shape[1]):
        ui = _rotate_min(u[:, i - 1], T[:, i - 1], T[:, i])
        ui -= (ui * T[:, i]).sum(axis=1, keepdims=True) * T[:, i]
        u[:, i] = _normalize(ui)
    v = np.cross(T, u)
    return T, u, v


# ---------------------------------------------------------------------------- growth


def parted_comb(positions: np.ndarray, parting: float, rng: np.random.Generator | None = None,
                fringe: bool = False) -> np.ndarray:
    """(N, 3) unit combing directions (before projection onto the surface) for hair parted at
    x = ``parting`` (head frame: Y up, face toward +Z): away from the parting and back over
    the top and the front, back and down behind the crown; with ``fringe`` the roots over the
    forehead (in front of z = 0.03 m, within 5 cm of the midline) comb forward instead."""
    p = np.asarray(positions, dtype=np.float64)
    off = p[:, 0] - parting
    side = np.sign(off)
    tie = side == 0
    if tie.any():
        side[tie] = np.where((rng.random(int(tie.sum())) if rng is not None else 0.0) < 0.5, -1.0, 1.0)
    # sideways and back at the parting, more and more back away from it (a swirl off the face).
    # Back at least as much as sideways: hair from the front hairline sweeps up and over the
    # head instead of lying along the hairline (a purely sideways comb laid the front locks
    # across the top of the forehead as dark bars).
    away = _smoothstep01(np.abs(off) / 0.05)
    front = np.stack([side * (0.7 - 0.3 * away), np.zeros_like(off), -(0.8 + 0.5 * away)], axis=1)
    behind = np.stack([0.08 * side, -np.ones_like(off), -0.35 * np.ones_like(off)], axis=1)
    # 0 in front of the crown, 1 behind it: the parting runs back to the crown (z = -0.02 m,
    # just behind the vertex) before the hair turns down the back of the head
    w = _smoothstep01((-0.02 - p[:, 2]) / 0.07)[:, None]
    comb = (1.0 - w) * _normalize(front) + w * _normalize(behind)
    if fringe:
        f = (_smoothstep01((p[:, 2] - 0.03) / 0.02) * _smoothstep01((0.05 - np.abs(p[:, 0])) / 0.015))[:, None]
        forward = np.stack([0.15 * np.sign(p[:, 0]), np.zeros(len(p)), np.ones(len(p))], axis=1)
        comb = (1.0 - f) * _normalize(comb) + f * _normalize(forward)
    return _normalize(comb)


def trim_before_box(p: np.ndarray, lo, hi, clearance: float) -> tuple[np.ndarray, np.ndarray]:
    """Strands (S, N, 3) that enter the box [lo, hi] resampled to end ``clearance`` of arc
    length before they do (the same N points, evenly spaced); returns (points, cut mask)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    S, n, _ = p.shape
    inside = np.all((p >= lo) & (p <= hi), axis=2)
    inside[:, 0] = False  # a root in the box (not on the default scalp) stays
    cut = inside.any(axis=1)
    if not cut.any():
        return p, cut
    seg = np.linalg.norm(np.diff(p, axis=1), axis=2)
    s = np.concatenate([np.zeros((S, 1)), np.cumsum(seg, axis=1)], axis=1)
    first = np.argmax(inside, axis=1)
    out = p.copy()
    for i in np.flatnonzero(cut):
        end = max(s[i, first[i]] - clearance, 0.25 * s[i, first[i]], 1e-4)
        t = np.linspace(0.0, end, n)
        out[i] = np.stack([np.interp(t, s[i], p[i, :, k]) for k in range(3)], axis=1)
    return out, cut


def _centrelines(fol: Follicles, seg: np.ndarray, n: int, st: StyleSettings,
                 collider: SurfaceProximity, rng: np.random.Generator) -> np.ndarray:
    S = len(fol)
    g = _normalize(np.asarray(st.gravity, dtype=np.float64))
    # initial direction: the normal tilted at random by up to direction_jitter
    ang = rng.random(S) * 2 * np.pi
    tilt = np.tan(st.direction_jitter * np.sqrt(rng.random(S)))
    d = _normalize(fol.normals + tilt[:, None] * (np.cos(ang)[:, None] * fol.tangents
                                                   + np.sin(ang)[:, None] * fol.bitangents))
    if st.sweep > 0:
        if st.parting is None:
            w = np.broadcast_to(_normalize(np.asarray(st.sweep_direction, dtype=np.float64)), (S, 3))
        else:
            w = parted_comb(fol.positions, st.parting, rng, st.fringe)
        w = w - (fol.normals * w).sum(axis=1, keepdims=True) * fol.normals  # along the surface
        d = _normalize(d + st.sweep * _normalize(w))
    p = np.empty((S, n, 3))
    p[:, 0] = fol.positions
    bend = (st.droop * seg / st.droop_length)[:, None]
    for i in range(1, n):
        d = _normalize(d + bend * g)
        q = p[:, i - 1] + seg[:, None] * d
        q = collider.push_out(q, st.collision_margin)
        d = _normalize(q - p[:, i - 1])
        p[:, i] = p[:, i - 1] + seg[:, None] * d
    return p


def _clump_centres(roots: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Clump leader strands about ``radius`` apart, and each strand's leader."""
    from scipy.spatial import cKDTree

    from .follicles import _first_independent_set

    tree = cKDTree(roots)
    keep = _first_independent_set(len(roots), tree.query_pairs(radius, output_type="ndarray"))
    leaders = np.flatnonzero(keep)
    _, nearest = cKDTree(roots[leaders]).query(roots)
    return leaders, leaders[nearest]


def grow_strands(fol: Follicles, mesh: Mesh, st: StyleSettings, points_per_strand: int,
                 rng: np.random.Generator, collider: SurfaceProximity | None = None):
    """(S, N, 3) strand points, (S,) lengths and (S,) clump leader of each strand."""
    st = st.validate()
    n = int(points_per_strand)
    S = len(fol)
    collider = collider or SurfaceProximity(mesh)
    collider.reach = max(collider.reach, 1.5 * float(st.length) * 2.0 / (n - 1))
    lengths = st.length * np.clip(1.0 + st.length_variation * rng.standard_normal(S), 0.3, 2.0)
    axial = lengths.copy()
    if st.kind == "curly":  # the helix's arc is longer than its axis
        axial *= st.curl_pitch / np.hypot(2 * np.pi * st.curl_radius, st.curl_pitch)
    seg = axial / (n - 1)
    p = _centrelines(fol, seg, n, st, collider, rng)
    s = seg[:, None] * np.arange(n)[None, :]  # axial arc length at every point
    leader = np.arange(S)
    if st.clump_radius > 0 and S > 1:  # clumps wave together even when not pulled in
        _, leader = _clump_centres(fol.positions, st.clump_radius)
    if st.kind in ("wavy", "curly"):
        # a clump waves (or curls) as one lock: its strands take their leader's phase and side
        _, u, v = transported_frames(p, fol.tangents)
        ramp = _smoothstep01(s / st.curl_start) if st.curl_start > 0 else np.ones_like(s)
        phase = (rng.random(S) * 2 * np.pi)[leader][:, None]
        if st.kind == "wavy":
            psi = (rng.random(S) * 2 * np.pi)[leader][:, None, None]
            side = np.cos(psi) * u + np.sin(psi) * v
            amp = st.wave_amplitude * ramp * np.sin(2 * np.pi * s / st.wave_length + phase)
            p = p + amp[..., None] * side
        else:
            hand = np.where(rng.random(S) < 0.5, -1.0, 1.0)[leader][:, None]
            theta = hand * (2 * np.pi * s / st.curl_pitch) + phase
            r = st.curl_radius * ramp
            # centred on the axis: the root sits on the follicle because the ramp is 0 there
            p = p + (r * np.cos(theta))[..., None] * u + (r * np.sin(theta))[..., None] * v
    if st.clump_strength > 0 and S > 1:
        t = np.linspace(0.0, 1.0, n)[None, :, None]
        pull = st.clump_strength * t ** st.clump_taper
        p = p + pull * (p[leader] - p)
    # keep every point but the root out of the mesh (clumps may have pulled some in deep)
    inner = collider.push_out(p[:, 1:].reshape(-1, 3), st.collision_margin * 0.5, reach=0.08)
    p[:, 1:] = inner.reshape(S, n - 1, 3)
    if st.face_box is not None:
        p, cut = trim_before_box(p, st.face_box[0], st.face_box[1], st.face_clearance)
        lengths = np.where(cut, np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1), lengths)
    return p, lengths, leader


def grow(
    mesh: Mesh | None = None,
    num_strands: int = 10000,
    style: str | StyleSettings = "straight",
    points_per_strand: int = 32,
    seed: int = 0,
    *,
    region=None,
    blue_noise: bool = False,
    follicles: Follicles | None = None,
    **overrides,
) -> Groom:
    """Grow a procedural groom on ``mesh`` (the default head when None).

    style: a preset name (see ``PRESETS``) or ``StyleSettings``; ``overrides`` replace fields
    (``length=0.3, curl_radius=0.01``...). region: where follicles go (see ``sample_follicles``);
    by default the painted scalp (red vertex colour >= 0.5) of a mesh with colours, else the
    whole mesh. follicles: use these roots instead of sampling. Deterministic by seed.

    The Groom carries widths, optional colours, and per-strand attributes ``root_normal``,
    ``root_tangent`` (float32 (S, 3)), ``face_index`` (int32), ``root_barycentric`` (float32
    (S, 3)) and ``clump`` (int32: the strand index of the clump's centre strand).
    """
    from .head import default_head

    unknown = set(overrides) - {f.name for f in fields(StyleSettings)}
    if unknown:
        raise TypeError(f"grow() got unexpected keyword arguments: {', '.join(sorted(unknown))}")
    st = style_settings(style, **overrides)
    n = int(points_per_strand)
    if n < 2 or n > 4096:
        raise UsageError(f"points per strand must be in 2..4096, got {n}")
    mesh = default_head() if mesh is None else mesh
    if st.face_box is None and str(dict(mesh.metadata).get("source", "")).endswith("default_head"):
        from .head import FACE_BOX

        st = replace(st, face_box=FACE_BOX)
    if follicles is None:
        if int(num_strands) <= 0:
            raise UsageError(f"the number of strands must be positive, got {num_strands}")
        if region is None and mesh.colors is not None and float(mesh.colors[:, 0].max()) > 0:
            region = VertexColorRegion(0, 0.5)
        follicles = sample_follicles(mesh, int(num_strands), region=region,
                                     method="blue_noise" if blue_noise else "uniform", seed=seed)
    rng = np.random.default_rng([int(seed), 0x6A6F])
    p, lengths, leader = grow_strands(follicles, mesh, st, n, rng)
    S = len(follicles)
    t = np.linspace(0.0, 1.0, n)
    widths = st.root_width * (1.0 - (1.0 - st.tip_width_ratio) * t ** 2)
    widths = np.broadcast_to(widths, (S, n)).reshape(-1)
    colors = None
    if st.color is not None:
        base = np.asarray(st.color, dtype=np.float64)
        var = 1.0 + st.color_variation * rng.standard_normal(S)
        col = base[None, None, :] * var[:, None, None] * (1.0 + 0.2 * t)[None, :, None]
        colors = np.clip(col, 0.0, 1.0).reshape(-1, 3)
    return Groom(
        p.reshape(-1, 3).astype(np.float32),
        np.full(S, n, dtype=np.int32),
        widths=widths.astype(np.float32),
        colors=None if colors is None else colors.astype(np.float32),
        strand_attributes={
            "root_normal": follicles.normals.astype(np.float32),
            "root_tangent": follicles.tangents.astype(np.float32),
            "face_index": follicles.face_index.astype(np.int32),
            "root_barycentric": follicles.barycentrics.astype(np.float32),
            "clump": leader.astype(np.int32),
        },
        metadata={
            "generator": "mane.grooming.grow",
            "style": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(st).items()},
            "seed": int(seed),
            "sampling": "blue_noise" if blue_noise else "uniform",
            "mesh": dict(mesh.metadata).get("source", "mesh"),
        },
    )


__all__ = ["StyleSettings", "PRESETS", "KINDS", "style_settings", "grow", "grow_strands",
           "transported_frames"]
