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

from dataclasses import dataclass, fields

import numpy as np

from ..errors import UsageError
from ..setting import setting, validate
from .grid_friction import METHOD_ALIASES as GRID_METHOD_ALIASES
from .grid_friction import METHODS as GRID_METHODS
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


GRID_OPTIONS = ("float_atomics", "splat", "chunk", "vertex_layer", "aggregate", "sorted_copy", "cell_sort")
"""Keyword arguments of ``GridFriction`` that ``SolverTuning.grid_options`` may set."""


@dataclass(frozen=True)
class SolverTuning:
    """How the solver's kernels are built and folded: the same results (to float round-off),
    other speeds. ``SimSettings.solver``; ``mane bench sim`` records them with every row."""

    shape_pipeline: int = setting(2, lo=1, hi=4,
        help="""shape iterations pipelined in one pass over a strand (1..4; the others take a pass
        each, through memory). More stages mean more registers per thread; 2 was the fastest
        measured (docs/performance.md).""")
    strand_group_size: int = setting(32, choices=(32, 64, 128, 256),
        help="""work group size of the per-strand kernels (one thread per strand); 32 was the fastest
        measured (docs/performance.md).""")
    cull_prims: bool = setting(True,
        help="""per-strand kernel: the collision primitives out of a strand's reach are not tested
        (strand_solve.comp's CULL_PRIMS): the same results, faster (docs/performance.md).""")
    keep_corrections: bool = setting(False,
        help="""the fused strand solve (velocities in the kernel) also writes DFTL's d_k to the
        corrections buffer (only ``velocity.comp`` reads it; tests, diagnostics).""")
    fold_integrate: bool = setting(False,
        help="""with DFTL and ``fused_strand_solve`` the fused strand solve also does integrate's
        work as it first reads each vertex (``folded_passes`` then lists integrate -> length).
        Off by default: it saved nothing measurable (docs/performance.md), as one thread per strand
        reads and writes the particle buffers with a stride of NV vec4s (uncoalesced) where
        integrate's per-particle pass is coalesced.""")
    fold_gather: bool = setting(True,
        help="""``substep`` with grid friction, no volume pass after it and integrate run as its own
        pass: friction's gather (v <- (1 - f) v + f V(x)) is left to the next step's integrate
        pass, with the grid and the positions this step leaves (the same result, one pass over the
        particles less). False gathers in the friction pass (comparisons, benchmarks).""")
    fold_guard: bool = setting(True,
        help="""with the fused strand solve and no volume pass: the NaN guard's tests and recoveries
        are done by the length pass's kernel as it leaves each strand (``folded_passes`` lists guard
        -> length), before the friction grid sees the particles. False runs the guard's own pass
        after friction (comparisons, benchmarks).""")
    fold_bounds: bool = setting(True,
        help="""``substep`` with grid friction and DFTL (no mesh collider left to the sdf pass): the
        length pass's kernel also reduces the positions it leaves into the friction grid's box, so
        the friction pass only pads it. False leaves the reduction to the friction pass.""")
    grid_options: dict = setting(factory=dict, keys=GRID_OPTIONS,
        help="""keyword arguments of the friction pass's ``GridFriction`` (``float_atomics``,
        ``splat``, ``chunk``, ``vertex_layer``, ``aggregate``, ``sorted_copy``, ``cell_sort``;
        GridFriction checks their values).""")

    def __post_init__(self) -> None:
        validate(self, "solver.")

    def strand_defines(self) -> dict:
        """The per-strand kernel's switches as strand_solve.comp's defines."""
        return {"CULL_PRIMS": int(self.cull_prims)}


@dataclass(frozen=True)
class SimSettings:
    """Everything the strand solver's step reads."""

    # ---- time
    dt: float = setting(1.0 / 120.0, lo=MIN_DT, hi=MAX_DT, unit="s", slider=(1.0 / 480.0, MAX_DT), format="%.5f",
        help="fixed simulation step, s; ``advance(frame_dt)`` runs as many as fit.")
    substeps: int = setting(1, lo=1, hi=64, slider=(1, 16),
        help="each fixed step is split into this many equal sub-steps (1..64).")
    max_substeps: int = setting(8, lo=1, hi=1000, slider=(1, 64),
        help="""the most fixed steps one ``advance()`` runs (catch-up clamp); the rest of the
        accumulated time is dropped so that a slow frame cannot snowball.""")

    # ---- forces
    gravity: tuple[float, float, float] = setting((0.0, -9.81, 0.0), lo=-MAX_GRAVITY, hi=MAX_GRAVITY, unit="m/s^2",
        help="gravitational acceleration, m/s^2 (world frame).")
    damping: float = setting(1.0, lo=0.0, hi=10000.0, unit="1/s", slider=(0.0, 20.0),
        help="velocity damping rate, 1/s: v *= exp(-damping * dt) every step.")
    drag: float = setting(0.0, lo=0.0, hi=10000.0, unit="1/s", slider=(0.0, 20.0),
        help="""linear air drag rate toward the wind velocity, 1/s: a += drag * (w - v).
        With no wind this is plain air resistance; wind acts only through it.""")
    max_speed: float = setting(30.0, lo=0.001, hi=100000.0, unit="m/s", slider=(0.1, 100.0),
        help="particle speeds are clamped to this, m/s.")
    wind: WindSettings = setting(factory=WindSettings,
        help="mean wind and gusts (see ``mane.sim.wind``).")

    # ---- length
    length_method: str = setting("dftl", choices=LENGTH_METHODS,
        help="""'dftl': Dynamic Follow-The-Leader (Müller et al. 2012), exact lengths in one
        root-to-tip pass; 'pbd': XPBD distance constraints (Macklin et al. 2016), each iteration
        a direct solve of the whole strand's constraint chain (a tridiagonal system, Goldenthal
        et al. 2007 / Deul et al. 2018), ``pbd_iterations`` times, in shared memory.""")
    pbd_iterations: int = setting(16, lo=1, hi=256, slider=(1, 64),
        help="""PBD iterations per step (1..256): Newton steps on the strand's length constraints,
        so the length error falls quadratically with them (Sintel nodding, bending on: within 1% at 16, as Chen ran 20);
        the stiffness is ``stretch_compliance``'s alone, not the count's.""")
    stretch_compliance: float = setting(0.0, lo=0.0, hi=1000.0, unit="s^2", slider=(0.0, 1e-3), format="%.2e",
        help="""PBD only: XPBD compliance of every segment, s^2 (per unit particle mass): a segment
        carrying the weight of n particles under gravity g stretches by compliance * n * g metres
        once converged, whatever ``pbd_iterations``; 0: inextensible.""")
    dftl_damping: float = setting(0.9, lo=0.0, hi=1.0,
        help="""s_damping of DFTL's velocity correction v_i += s * (-d_{i+1}) / dt, in [0, 1].
        (A strand hanging at rest keeps a velocity along itself of about s g dt / (1 - s);
        FTL removes it every step, so it never shows as motion.)""")
    fused_strand_solve: bool = setting(True,
        help="""DFTL only: run local shape, bending, DFTL with the collisions and the velocity update
        as one per-strand kernel (the 'length' pass; each strand is read and written once per
        step) instead of the separate shape, length and velocity passes. Same results up to
        float round-off.""")
    long_range_attachment: bool = setting(False,
        help="""tether every particle to its root with its rest arc length (PBD only: DFTL's
        exact lengths already keep every particle within its arc length).""")

    # ---- shape
    global_shape_stiffness: float = setting(0.0, lo=0.0, hi=1.0,
        help="fraction of the way to the skinned rest position each step, in [0, 1] (TressFX).")
    global_shape_range: float = setting(1.0, lo=0.0, hi=1.0,
        help="""part of the strand, from the root, under global shape: particle k of N is
        affected when k / (N - 1) <= range; in [0, 1].""")
    local_shape_stiffness: float = setting(0.0, lo=0.0, hi=1.0,
        help="""stiffness of the bind-pose frames propagated root to tip, in [0, 1] per step:
        each joint turns the fraction k of the way back to its bind direction every step
        (the strand below it following), so small values (0.01..0.2) already hold a style.""")
    bending_stiffness: float = setting(0.0, lo=0.0, hi=1.0,
        help="""a kink limiter, not a physical bending stiffness (no EI: a cantilever's sag does not
        follow w L^4 / (8 EI)): in [0, 1] per step, a joint bent beyond its rest angle is unbent
        this fraction of the excess, in its plane (the strand below it turning rigidly); a joint
        bent less than at rest gets nothing. So straight rest hair is held straight (a cantilever
        stays up), but curved rest hair moves freely until its joints pass their rest angles (on
        real grooms it changes little): local_shape_stiffness holds a styled shape.""")
    shape_iterations: int = setting(2, lo=1, hi=64, slider=(1, 16),
        help="""Gauss-Seidel sweeps of local shape and bending per step (1..64); stiffness is
        converted per iteration, so the count changes convergence, not stiffness.""")

    # ---- hair-hair (run by mane.sim.grid_friction / mane.sim.flip when present)
    friction: float = setting(0.0, lo=0.0, hi=1.0,
        help="hair-hair friction: blend of each velocity toward the grid's mean, in [0, 1].")
    grid_method: str = setting("splat", choices=GRID_METHODS + tuple(GRID_METHOD_ALIASES),
        help="how the friction grid is built (see ``mane.sim.grid_friction``).")
    grid_resolution: int = setting(32, lo=4, hi=256,
        help="voxels per axis of the hair-hair grid (4..256).")
    volume: bool = setting(False,
        help="""run FLIP volume preservation (``mane.sim.flip``, Chen's method): the velocities made
        divergence-free on the hair's grid, and cells denser than the groom's rest density (its mean
        over occupied cells at rest, per m^3) pushed apart, so the hair keeps its rest volume.""")
    flip_ratio: float = setting(0.95, lo=0.0, hi=1.0,
        help="FLIP/PIC blend of the volume pass: 1 pure FLIP, 0 pure PIC.")

    # ---- robustness
    nan_guard: bool = setting(True,
        help="""after each step, reset strands that hold NaN/inf or absurd values to their last
        valid positions (zero velocity) and count them (``Simulator.nan_recoveries``).""")
    max_stretch: float = setting(4.0, lo=1.0, hi=1000000.0, slider=(1.0, 10.0),
        help="""a particle farther from its root than ``max_stretch`` times its rest arc length
        plus 1 cm is absurd (triggers the guard).""")

    # ---- kernels
    solver: SolverTuning = setting(factory=SolverTuning,
        help="how the kernels are built and folded (same results, other speeds; see SolverTuning).")

    def __post_init__(self) -> None:
        validate(self)   # every field against its declaration (mane.setting); then the magnitude of gravity
        g = float(np.linalg.norm(self.gravity))
        if g > MAX_GRAVITY:
            raise UsageError(f"gravity of {g:.3g} m/s^2 is beyond the {MAX_GRAVITY:g} m/s^2 "
                             f"(about 100 g) the solver handles; speeds would overflow")

    @classmethod
    def field_docs(cls) -> dict[str, str]:
        """name -> the field's help (its declaration's, mane.setting)."""
        return {f.name: f.metadata.get("help", "") for f in fields(cls)}


