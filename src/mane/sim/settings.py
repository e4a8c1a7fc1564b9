"""Solver settings: frozen dataclasses, units in every field's doc.

A ``Simulator`` reads its ``settings`` at every step, so replacing them between steps
(``sim.settings = dataclasses.replace(sim.settings, drag=2.0)``) takes effect at once.

Stiffness convention. Every shape stiffness ``k`` in [0, 1] is the fraction of the
constraint error removed *per step* (per sub-step when ``substeps > 1``). Constraints
that are iterated (local shape and bending, ``shape_iterations`` times) are applied with
the per-iteration stiffness ``k_it = 1 - (1 - k) ** (1 / n)`` (Müller et al. 2007, §3.3),
so that n iterations remove ``1 - (1 - k_it) ** n = k`` of a constraint's error. For an
isolated constraint that is exact; for a chain it holds because both constraints act on
joint angles and each correction moves the strand below the joint rigidly, leaving the
other joints' errors alone (tested: 2 and 8 iterations agree within a few % of the
constraint's effect). Length constraints are hard in both methods (PBD: unless
``stretch_compliance`` > 0, an XPBD compliance, which is iteration-independent too).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from ..errors import UsageError
from .wind import WindSettings

LENGTH_METHODS = ("dftl", "pbd")

MIN_DT = 1e-5
"""Smallest accepted step, s."""
MAX_DT = 1.0 / 15.0
"""Largest accepted step, s (a step above this is clamped to it)."""


def iteration_stiffness(k: float, iterations: int) -> float:
    """Per-iteration stiffness giving a total of ``k`` over ``iterations`` iterations."""
    k = min(max(float(k), 0.0), 1.0)
    n = max(int(iterations), 1)
    if k >= 1.0:
        return 1.0
    return 1.0 - (1.0 - k) ** (1.0 / n)

MAX_GRAVITY = 1000.0
"""Largest |gravity| accepted, m/s^2 (about 100 g): beyond it speeds overflow float32 within steps."""


@dataclass(frozen=True)
class SimSettings:
    """Everything the strand solver's step reads."""

    # ---- time
    dt: float = 1.0 / 120.0
    """fixed simulation step, s; ``advance(frame_dt)`` runs as many as fit."""
    substeps: int = 1
    """each fixed step is split into this many equal sub-steps (1..64)."""
    max_substeps: int = 8
    """the most fixed steps one ``advance()`` runs (catch-up clamp); the rest of the
    accumulated time is dropped so that a slow frame cannot snowball."""

    # ---- forces
    gravity: tuple[float, float, float] = (0.0, -9.81, 0.0)
    """gravitational acceleration, m/s^2 (world frame)."""
    damping: float = 1.0
    """velocity damping rate, 1/s: v *= exp(-damping * dt) every step."""
    drag: float = 0.0
    """linear air drag rate toward the wind velocity, 1/s: a += drag * (w - v).
    With no wind this is plain air resistance; wind acts only through it."""
    max_speed: float = 30.0
    """particle speeds are clamped to this, m/s."""
    wind: WindSettings = field(default_factory=WindSettings)
    """mean wind and gusts (see ``mane.sim.wind``)."""

    # ---- length
    length_method: str = "dftl"
    """'dftl': Dynamic Follow-The-Leader (Müller et al. 2012), exact lengths in one
    root-to-tip pass; 'pbd': XPBD distance constraints (Macklin et al. 2016), each iteration
    a direct solve of the whole strand's constraint chain (a tridiagonal system, Goldenthal
    et al. 2007 / Deul et al. 2018), ``pbd_iterations`` times, in shared memory."""
    pbd_iterations: int = 16
    """PBD iterations per step (1..256): Newton steps on the strand's length constraints,
    so the length error falls quadratically with them (Sintel nodding, bending on: within 1% at 16, as Chen ran 20);
    the stiffness is ``stretch_compliance``'s alone, not the count's."""
    stretch_compliance: float = 0.0
    """PBD only: XPBD compliance of every segment, s^2 (per unit particle mass): a segment
    carrying the weight of n particles under gravity g stretches by compliance * n * g metres
    once converged, whatever ``pbd_iterations``; 0: inextensible."""
    dftl_damping: float = 0.9
    """s_damping of DFTL's velocity correction v_i += s * (-d_{i+1}) / dt, in [0, 1].
    (A strand hanging at rest keeps a velocity along itself of about s g dt / (1 - s);
    FTL removes it every step, so it never shows as motion.)"""
    fused_strand_solve: bool = True
    """DFTL only: run local shape, bending, DFTL with the collisions and the velocity update
    as one per-strand kernel (the 'length' pass; each strand is read and written once per
    step) instead of the separate shape, length and velocity passes. Same results up to
    float round-off."""
    long_range_attachment: bool = False
    """tether every particle to its root with its rest arc length (PBD only: DFTL's
    exact lengths already keep every particle within its arc length)."""

    # ---- shape
    global_shape_stiffness: float = 0.0
    """fraction of the way to the skinned rest position each step, in [0, 1] (TressFX)."""
    global_shape_range: float = 1.0
    """part of the strand, from the root, under global shape: particle k of N is
    affected when k / (N - 1) <= range; in [0, 1]."""
    local_shape_stiffness: float = 0.0
    """stiffness of the bind-pose frames propagated root to tip, in [0, 1] per step:
    each joint turns the fraction k of the way back to its bind direction every step
    (the strand below it following), so small values (0.01..0.2) already hold a style."""
    bending_stiffness: float = 0.0
    """a kink limiter, not a physical bending stiffness (no EI: a cantilever's sag does not
    follow w L^4 / (8 EI)): in [0, 1] per step, a joint bent beyond its rest angle is unbent
    this fraction of the excess, in its plane (the strand below it turning rigidly); a joint
    bent less than at rest gets nothing. So straight rest hair is held straight (a cantilever
    stays up), but curved rest hair moves freely until its joints pass their rest angles (on
    real grooms it changes little): local_shape_stiffness holds a styled shape."""
    shape_iterations: int = 2
    """Gauss-Seidel sweeps of local shape and bending per step (1..64); stiffness is
    converted per iteration, so the count changes convergence, not stiffness."""

    # ---- hair-hair (run by mane.sim.grid_friction / mane.sim.flip when present)
    friction: float = 0.0
    """hair-hair friction: blend of each velocity toward the grid's mean, in [0, 1]."""
    grid_method: str = "splat"
    """how the friction grid is built (see ``mane.sim.grid_friction``)."""
    grid_resolution: int = 32
    """voxels per axis of the hair-hair grid (4..256)."""
    volume: bool = False
    """run FLIP volume preservation (``mane.sim.flip``, Chen's method): the velocities made
    divergence-free on the hair's grid, and cells denser than the groom's rest density (its mean
    over occupied cells at rest, per m^3) pushed apart, so the hair keeps its rest volume."""
    flip_ratio: float = 0.95
    """FLIP/PIC blend of the volume pass: 1 pure FLIP, 0 pure PIC."""

    # ---- robustness
    nan_guard: bool = True
    """after each step, reset strands that hold NaN/inf or absurd values to their last
    valid positions (zero velocity) and count them (``Simulator.nan_recoveries``)."""
    max_stretch: float = 4.0
    """a particle farther from its root than ``max_stretch`` times its rest arc length
    plus 1 cm is absurd (triggers the guard)."""

    def __post_init__(self) -> None:
        g = np.asarray(self.gravity, dtype=float).reshape(-1)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise UsageError(f"gravity must be 3 finite numbers (m/s^2), got {self.gravity!r}")
        if float(np.linalg.norm(g)) > MAX_GRAVITY:
            raise UsageError(f"gravity of {float(np.linalg.norm(g)):.3g} m/s^2 is beyond the {MAX_GRAVITY:g} m/s^2 "
                             f"(about 100 g) the solver handles; speeds would overflow")
        object.__setattr__(self, "gravity", tuple(float(x) for x in g))
        if not np.isfinite(self.dt) or not MIN_DT <= self.dt <= MAX_DT:
            raise UsageError(f"dt must be in [{MIN_DT}, {MAX_DT:.4f}] s, got {self.dt}")
        _int_range(self, "substeps", 1, 64)
        _int_range(self, "max_substeps", 1, 1000)
        _int_range(self, "pbd_iterations", 1, 256)
        _int_range(self, "shape_iterations", 1, 64)
        _int_range(self, "grid_resolution", 4, 256)
        for name in ("damping", "drag"):
            _float_range(self, name, 0.0, 1e4)
        _float_range(self, "stretch_compliance", 0.0, 1e3)
        _float_range(self, "max_speed", 1e-3, 1e5)
        _float_range(self, "max_stretch", 1.0, 1e6)
        for name in ("dftl_damping", "global_shape_stiffness", "global_shape_range",
                     "local_shape_stiffness", "bending_stiffness", "friction", "flip_ratio"):
            _float_range(self, name, 0.0, 1.0)
        if self.length_method not in LENGTH_METHODS:
            raise UsageError(f"length_method must be one of {LENGTH_METHODS}, got {self.length_method!r}")
        if not isinstance(self.wind, WindSettings):
            raise UsageError("wind must be a mane.sim.WindSettings")

    @classmethod
    def field_docs(cls) -> dict[str, str]:
        """name -> the field's doc string (for generated panels and CLI flags)."""
        import ast
        import inspect
        import textwrap

        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        body = tree.body[0].body
        docs = {}
        for a, b in zip(body, body[1:]):
            if (isinstance(a, ast.AnnAssign) and isinstance(b, ast.Expr)
                    and isinstance(getattr(b, "value", None), ast.Constant)):
                docs[a.target.id] = " ".join(str(b.value.value).split())
        return {f.name: docs.get(f.name, "") for f in fields(cls)}


def _int_range(obj, name: str, lo: int, hi: int) -> None:
    v = getattr(obj, name)
    try:
        iv = int(v)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be an integer, got {v!r}") from None
    if iv != v or not lo <= iv <= hi:
        raise UsageError(f"{name} must be an integer in {lo}..{hi}, got {v!r}")
    object.__setattr__(obj, name, iv)


def _float_range(obj, name: str, lo: float, hi: float) -> None:
    v = getattr(obj, name)
    try:
        fv = float(v)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {v!r}") from None
    if not np.isfinite(fv) or not lo <= fv <= hi:
        raise UsageError(f"{name} must be in [{lo}, {hi}], got {v!r}")
    object.__setattr__(obj, name, fv)
