"""The strand solver: a Simulator steps a SimState of GPU buffers with compute shaders.

    sim = Simulator(groom, colliders=[Sphere(center=(0, 1.6, 0), radius=0.09)],
                    settings=SimSettings(length_method="dftl"))
    for frame in range(240):
        sim.set_head_transform(head_motion.nod(frame / 60))
        sim.advance(1 / 60)            # as many fixed steps of settings.dt as fit
        pts = sim.positions()          # (P, 3) numpy; the renderer binds sim.state.positions

One (sub-)step, each a compute pass (``PASSES``; a pass with nothing to do is skipped):

    integrate  forces, prediction, pinned follicles, global shape    (per particle)
    shape      local shape + bending, Gauss-Seidel sweeps            (per strand)
    length     DFTL (per strand) or XPBD, a direct chain solve per iteration (per strand group),
               with the projection colliders and mesh SDFs inside: DFTL projects each
               particle out as its sweep places it and puts it back at its rest length from
               its leader (lengths stay exact); PBD projects between its iterations
    collide    projection colliders + friction, after the fact       (per particle)
    sdf        mesh colliders after the fact (mane.sim.sdf), beyond those the sweeps take
    velocity   v = (x - x_prev) / dt (+ DFTL correction)             (per particle)
    friction   hair-hair grid friction (mane.sim.grid_friction)
    volume     FLIP volume (mane.sim.flip)
    guard      NaN / absurd-value recovery        (per particle, strands in shared memory)

Some passes are folded into another (``Simulator.folded_passes()``, pass -> the one that
does its work) and not run by ``substep``: ``collide`` and ``sdf`` into ``length`` always
(only mesh colliders beyond the first ``MAX_SWEEP_SDFS`` are left to the sdf pass), and
with DFTL and ``settings.fused_strand_solve`` (the default) also ``shape`` and ``velocity``
(and ``integrate`` with ``SolverTuning.fold_integrate``): then one per-strand kernel
(``strand_solve.comp``) streams each strand once per step through shape, DFTL, collisions
and the velocity update. ``substep`` also moves two stages of the friction pass into
neighbouring kernels (``fold_bounds``: the grid box's reduction into the length pass;
``fold_gather``: the gather into the next step's integrate pass, see below), and with the
fused solve the guard's tests and recoveries into the length pass (``fold_guard``).
``run_pass`` still runs a folded pass's own kernel on its own (tests, diagnostics).

A deferred gather: the velocities a step leaves in the GPU buffer lack its friction
gather (v <- (1 - f) v + f V(x)) until the next step's integrate pass applies it with the
grid and positions the step left (the same arithmetic, one pass over the particles less).
Reading the velocities on the CPU (``SimState.read``, ``state.velocities()``,
``snapshot``), writing any state buffer, ``run_pass`` and another state's friction pass
run the gather first (``SimState.settle``); positions are always final.

The simulator keeps no dynamic state of its own: everything that changes from step to
step lives in its ``SimState`` (``sim.state``), and every method takes ``state=`` to
step another one. It does cache GPU programs and the helper passes' grids (and which state
has a gather deferred onto its grid).
"""
from __future__ import annotations

import functools
import math
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import GroomError, UsageError
from ..gpu import compute_shader, get_context
from ..gpu.lifetime import GpuOwner
from ..gpu.profiler import GpuProfiler, profile_every
from ..groom import Groom
from ..phases import phase
from . import head_motion
from .bindings import B_GATHER_BOUNDS, B_GATHER_GRID, TEX_SDF_FIRST
from .colliders import Collider, MeshCollider, pack_colliders
from .flip import FlipVolume
from .grid_friction import GridFriction
from .sdf import MeshSDF
from .settings import MAX_DT, MIN_DT, SimSettings, iteration_stiffness
from .state import BINDINGS, MAX_POINTS_PER_STRAND, SimState, transform_points

HERE = Path(__file__).resolve().parent
PASSES = ("integrate", "shape", "length", "collide", "sdf", "velocity", "friction", "volume", "guard")
DEFAULT_POINTS_PER_STRAND = 16
MAX_SWEEP_SDFS = 4
"""mesh colliders handled inside the length pass's sweeps (texture units 5..8); more go
to the sdf pass after it."""
SDF_UNIT0 = TEX_SDF_FIRST
GATHER_GRID_BINDING = B_GATHER_GRID   # integrate with a deferred friction gather: the grid and its box
GATHER_BOUNDS_BINDING = B_GATHER_BOUNDS
AUX_BOUNDS_BINDING = B_GATHER_BOUNDS  # the length pass reducing into the friction grid's box


def _mat4(m) -> tuple:
    """A row-major NumPy 4x4 as the column-major tuple GLSL wants (one tuple object per value:
    the head's matrix is asked for by two passes of every sub-step, mostly unchanged)."""
    return _mat4_of(np.asarray(m, dtype=np.float64).tobytes())


@functools.lru_cache(maxsize=8)
def _mat4_of(raw: bytes) -> tuple:
    return tuple(float(x) for x in np.frombuffer(raw, np.float64).reshape(4, 4).T.reshape(-1))


def _set(shader, name: str, value) -> None:
    """Set a uniform the kernel kept (drivers drop unused ones). The simulator's kernels get their
    uniforms only through here and ``_write``, which remember the last value on the uniform and
    skip the GL call when it has not changed (most uniforms stay the same from step to step)."""
    uniform = shader.get(name, None)
    if uniform is None:  # optimised away or unused by this kernel
        return
    if getattr(uniform, "_mane_last", None) != value:
        uniform.value = value
        uniform._mane_last = value


def _write(shader, name: str, data: bytes) -> None:
    """Raw bytes into a (uniform array) uniform, if the kernel has it."""
    uniform = shader.get(name, None)
    if uniform is None:
        return
    if getattr(uniform, "_mane_last", None) != data:
        uniform.write(data)
        uniform._mane_last = data


@dataclass
class SimSnapshot:
    """A copy of a SimState's contents (CPU side), for ``Simulator.restore``."""

    buffers: dict
    length_scale: np.ndarray
    head: np.ndarray
    head_target: np.ndarray
    time: float
    steps: int
    accumulator: float
    collider_worlds: list | None = None
    mesh_worlds: list | None = None


@dataclass
class _Timer:
    queries: dict = field(default_factory=dict)  # name -> list of (query)
    totals: dict = field(default_factory=dict)  # name -> [ms sum, count]


class Simulator(GpuOwner):
    """GPU strand simulation of a groom (see the module doc)."""

    def __init__(self, groom, colliders=(), settings: SimSettings | None = None, ctx=None, *,
                 points_per_strand: int | None = None, head_transform=None, profile: bool | int = False):
        self.ctx = ctx if ctx is not None else get_context()
        self.settings = settings if settings is not None else SimSettings()
        self.groom = self._prepare(groom, points_per_strand)
        with phase("groom_check"):
            _check_coordinates(self.groom)
        self.colliders = list(colliders)
        for c in self.colliders:
            if not isinstance(c, (Collider, MeshCollider)):
                raise UsageError(f"not a collider: {c!r} (use mane.sim.Sphere, Ellipsoid, Capsule or MeshCollider)")
        S, N = self.groom.num_strands, int(self.groom.uniform_count)
        inv_mass = np.ones((S, N), dtype=np.float32)
        inv_mass[:, 0] = 0.0
        immovable = self.groom.point_attributes.get("immovable")
        if immovable is not None:
            inv_mass[np.asarray(immovable).reshape(S, N).astype(bool)] = 0.0
        n_prims = sum(isinstance(c, Collider) for c in self.colliders)
        self.state = SimState.allocate(self.ctx, self.groom.as_padded(), inv_mass.reshape(-1), n_prims)
        self._released = False
        if head_transform is not None:
            self.set_head_transform(head_transform)
            self.reset()
        self.warnings: list[str] = []
        self._warned: set[str] = set()
        self._shaders: dict = {}
        self._grid = None
        self._grid_key = None
        self._flip = None
        self._flip_key = None
        self._rest_density = None
        self._deferred: SimState | None = None   # the state whose gather waits on self._grid
        every = profile_every(profile)   # True: the profiler's default, N: every Nth step's passes
        self.profile = every != 0
        self._timer = _Timer()
        self._profiler = None
        if self.profile:
            self._profiler = GpuProfiler(self.ctx, every=every)

    # ------------------------------------------------------------------ set-up
    @staticmethod
    def _prepare(groom, points_per_strand):
        if not isinstance(groom, Groom):
            raise UsageError(f"groom must be a mane.Groom (mane.load reads a file), got {type(groom).__name__}")
        if points_per_strand is not None:
            n = int(points_per_strand)
            if not 2 <= n <= MAX_POINTS_PER_STRAND:
                raise UsageError(f"points_per_strand must be in 2..{MAX_POINTS_PER_STRAND}, got {n}")
            return groom if groom.uniform_count == n else groom.resampled(n)
        n = groom.uniform_count
        if n is None or n > MAX_POINTS_PER_STRAND:
            return groom.resampled(DEFAULT_POINTS_PER_STRAND)
        return groom

    @property
    def settings(self) -> SimSettings:
        return self._settings

    @settings.setter
    def settings(self, value: SimSettings) -> None:
        if not isinstance(value, SimSettings):
            raise UsageError("settings must be a mane.sim.SimSettings")
        self._settings = value

    def _warn(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self.warnings.append(message)

    def _shader(self, name: str, **defines):
        """The pass's program, cached per simulator (``compute_shader``'s own cache resolves
        paths and stats every source file on each call: CPU time in every pass of every step)."""
        key = (name, self.state.points_per_strand, tuple(defines.items()))   # a call site's order is fixed
        shader = self._shaders.get(key)
        if shader is None:
            shader = compute_shader(self.ctx, HERE / f"{name}.comp", {"NV": self.state.points_per_strand, **defines})
            self._shaders[key] = shader
        return shader

    # ------------------------------------------------------------------ inputs
    def set_head_transform(self, matrix, state: SimState | None = None) -> None:
        """Where the head is (head frame -> world, rigid 4x4) at the end of the next step or
        ``advance``; the follicles get there smoothly over its sub-steps."""
        m = np.asarray(matrix, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise UsageError("the head transform must be a finite 4x4 matrix")
        (state or self.state).head_target = m.copy()

    def set_length_scale(self, scale, state: SimState | None = None) -> None:
        """Haircut: cut every strand (scalar) or each strand ((S,) array) to ``scale`` of its
        rest arc length, in (0, 1]. Segments past the cut get rest length 0 (the tip particles
        gather at the cut); 1 restores the full length."""
        st = state or self.state
        s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (st.num_strands,)).copy()
        if not np.all(np.isfinite(s)) or np.any(s <= 0) or np.any(s > 1):
            raise UsageError("length scale must be in (0, 1] (a haircut cannot grow hair)")
        st.length_scale = s
        st.upload_rest()

    def reset(self, state: SimState | None = None) -> None:
        """Back to the rest pose at the head's target transform, at rest, time 0."""
        st = state or self.state
        st.head = np.array(st.head_target, dtype=np.float64)
        st.reset()

    def new_state(self) -> SimState:
        """Another state of the same groom (at rest), to step side by side with ``state=``."""
        return SimState.allocate(self.ctx, self.groom.as_padded(), self.state.inv_mass,
                                 sum(isinstance(c, Collider) for c in self.colliders))

    # ------------------------------------------------------------------ stepping
    def advance(self, frame_dt: float, state: SimState | None = None) -> int:
        """Add ``frame_dt`` seconds to the accumulator and run as many fixed steps of
        ``settings.dt`` as fit (at most ``settings.max_substeps``; time beyond that is
        dropped). The head moves from where it was to its target over these steps.
        Returns the number of steps run."""
        st = state or self.state
        frame_dt = float(frame_dt)
        if not math.isfinite(frame_dt) or frame_dt < 0:
            raise UsageError(f"frame time must be a finite number >= 0 s, got {frame_dt}")
        dt = self.settings.dt
        st.accumulator += frame_dt
        n = int(math.floor(st.accumulator / dt + 1e-6))
        if n > self.settings.max_substeps:
            n = self.settings.max_substeps
            st.accumulator = 0.0
        else:
            st.accumulator = max(st.accumulator - n * dt, 0.0)
        start, target = st.head.copy(), st.head_target.copy()
        for j in range(n):
            self._step(st, dt, head_motion.interpolate(start, target, j / n),
                       head_motion.interpolate(start, target, (j + 1) / n))
        return n

    def step(self, dt: float | None = None, state: SimState | None = None) -> None:
        """One fixed step (``settings.dt`` unless given; clamped to [MIN_DT, MAX_DT])."""
        st = state or self.state
        dt = self.settings.dt if dt is None else float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise UsageError(f"dt must be a finite number > 0 s, got {dt}")
        dt = min(max(dt, MIN_DT), MAX_DT)
        self._step(st, dt, st.head.copy(), st.head_target.copy())

    def _step(self, st: SimState, dt: float, head_from: np.ndarray, head_to: np.ndarray) -> None:
        n = self.settings.substeps
        h = dt / n
        for j in range(n):
            head = head_to if j == n - 1 else head_motion.interpolate(head_from, head_to, (j + 1) / n)
            self.substep(st, h, head)
        if self.profile and self._profiler is not None:
            self._profiler.frame()   # a step is the profiler's frame: its results read, its 'every' counted

    def substep(self, st: SimState, h: float, head: np.ndarray) -> None:
        """Every pass once (but the folded ones), with step ``h`` seconds and the head at ``head``."""
        st.head = np.asarray(head, dtype=np.float64)
        self.upload_colliders(st)
        folded = self.folded_passes()
        defer_gather = self._defer_gather()
        bounds_in_length = self._bounds_in_length()
        if self.settings.friction > 0:
            self._friction_grid()   # a new grid settles a gather deferred onto the old one first
        # the state's buffers are bound once; the passes that bind others (friction, volume, sdf)
        # bind them again when they are done
        self._bind(st)
        for name in PASSES:
            if name in folded:
                continue
            if name == "length":
                self._pass_length(st, h, bounds=bounds_in_length)
            elif name == "friction":
                self._pass_friction(st, h, gather=not defer_gather, reduced=bounds_in_length)
            else:
                getattr(self, f"_pass_{name}")(st, h)
        st.time += h
        st.steps += 1
        st.last_dt = h

    def upload_colliders(self, st: SimState) -> None:
        data, worlds = pack_colliders(self.colliders, st.head, st.collider_worlds)
        buf = st.buffers["colliders"]
        if data.nbytes > buf.size:
            buf.orphan(data.nbytes)
        buf.write(data.tobytes())
        st.collider_worlds = worlds
        st.num_colliders = len(worlds)
        meshes = [c.world_transform(st.head) for c in self.colliders if isinstance(c, MeshCollider)]
        prev = st.mesh_worlds if st.mesh_worlds is not None and len(st.mesh_worlds) == len(meshes) else meshes
        st.mesh_prev_worlds, st.mesh_worlds = prev, meshes

    def folded_passes(self) -> dict:
        """Passes that ``substep`` does not run because another does their work: name -> that pass."""
        folded = {"collide": "length", "sdf": "length"}
        if sum(isinstance(c, MeshCollider) for c in self.colliders) > MAX_SWEEP_SDFS:
            del folded["sdf"]
        if self._fused():
            folded.update(shape="length", velocity="length")
            if self.settings.solver.fold_integrate:
                folded["integrate"] = "length"
        if self._guard_in_length():
            folded["guard"] = "length"
        return folded

    def _fused(self) -> bool:
        return self.settings.length_method == "dftl" and self.settings.fused_strand_solve

    # ------------------------------------------------------------------ passes
    def _bind(self, st: SimState) -> None:
        for name, binding in BINDINGS.items():
            st.buffers[name].bind_to_storage_buffer(binding)

    def _dispatch(self, name: str, shader, groups: int) -> None:
        if groups <= 0:
            return
        with self._timed(name):
            shader.run(group_x=int(groups))
        self.ctx.memory_barrier()

    def run_pass(self, name: str, st: SimState | None = None, h: float | None = None) -> bool:
        """Run one pass of the step (``PASSES``) on ``st``; False when it had nothing to do.

        Exposed for tests and profiling; ``substep`` runs them all in order.
        """
        st = st or self.state
        h = self.settings.dt / self.settings.substeps if h is None else float(h)
        if st.collider_worlds is None:
            self.upload_colliders(st)
        method = getattr(self, f"_pass_{name}", None)
        if method is None:
            raise UsageError(f"unknown pass {name!r}; passes: {', '.join(PASSES)}")
        st.settle()
        self._bind(st)
        return bool(method(st, h))

    def _particle_groups(self, st: SimState) -> int:
        return (st.num_particles + 63) // 64

    def _strand_groups(self, st: SimState) -> int:
        return (st.num_strands + 63) // 64

    def _pass_integrate(self, st: SimState, h: float) -> bool:
        """integrate.comp; with the gather the last friction pass deferred (``fold_gather``) first."""
        if self._deferred is not None and self._deferred is not st:
            self._deferred.settle()   # another state's: the grid is about to serve this one
            self._bind(st)
        friction = st.take_pending()   # pending only while its grid is self._grid (see _deferred)
        self._deferred = None
        if friction is None:
            sh = self._shader("integrate", PENALTY=int(self._penalty_on()))
        else:
            grid = self._grid
            sh = self._shader("integrate", PENALTY=int(self._penalty_on()), GATHER=1, GRID_RES=grid.resolution,
                              GRID_BINDING=GATHER_GRID_BINDING, BOUNDS_BINDING=GATHER_BOUNDS_BINDING)
            grid.grid.bind_to_storage_buffer(GATHER_GRID_BINDING)
            grid.bounds.buffer.bind_to_storage_buffer(GATHER_BOUNDS_BINDING)
            _set(sh, "friction", friction)
        _set(sh, "num_strands", st.num_strands)
        self._integrate_uniforms(sh, st, h)
        self._dispatch("integrate", sh, self._particle_groups(st))
        return True

    def _penalty_on(self) -> bool:
        return any(isinstance(c, Collider) and c.mode == "penalty" for c in self.colliders)

    def _integrate_uniforms(self, sh, st: SimState, h: float) -> None:
        """integrate.comp's uniforms (also strand_solve.comp's with INTEGRATE)."""
        s = self.settings
        _set(sh, "num_colliders", st.num_colliders)
        _set(sh, "head", _mat4(st.head))
        _set(sh, "dt", h)
        _set(sh, "gravity", s.gravity)
        _set(sh, "damping_factor", math.exp(-s.damping * h))
        _set(sh, "drag", s.drag)
        _set(sh, "max_speed", s.max_speed)
        _set(sh, "global_stiffness", s.global_shape_stiffness)
        _set(sh, "global_range", s.global_shape_range)
        _set(sh, "time", st.time)
        wind = int(s.wind.active)
        _set(sh, "wind_on", wind)
        if wind:   # the kernels read the wind's uniforms only with wind_on
            for k, v in s.wind.uniforms().items():
                _set(sh, k, v)

    # per-strand sweeps: local shape, bending, DFTL, collisions, velocities (strand_solve.comp); how
    # they are built and folded: settings.solver (SolverTuning)
    def _shape_on(self) -> bool:
        s = self.settings
        return s.local_shape_stiffness > 0 or s.bending_stiffness > 0

    def _strand_solve(self, st: SimState, h: float, *, shape: bool, dftl: bool, velocity: bool,
                      contact: bool, integrate: bool = False, bounds=None, guard: bool = False) -> None:
        s = self.settings
        prims = self._sweep_prims(st) if contact else 0
        sdfs = self._sweep_sdfs(st) if contact else []
        stages = max(1, min(int(self.settings.solver.shape_pipeline), 4, s.shape_iterations)) if shape else 1
        # integrate in the first pass over the strand: a shape pre-pass when there is one
        mode = (2 if shape and s.shape_iterations > stages else 1) if integrate else 0
        defines = dict(SHAPE=int(shape), DFTL=int(dftl), VELOCITY=int(velocity), PRIMS=prims, NSDF=len(sdfs),
                       STAGES=stages, LOCAL_SIZE=int(self.settings.solver.strand_group_size), INTEGRATE=mode,
                       PENALTY=int(integrate and self._penalty_on()),
                       CORRECTIONS=int(not velocity or self.settings.solver.keep_corrections), BOUNDS=int(bounds is not None),
                       BOUNDS_BINDING=AUX_BOUNDS_BINDING, GUARD=int(guard))
        defines.update(self.settings.solver.strand_defines())
        sh = self._shader("strand_solve", **defines)
        if bounds is not None:
            bounds.buffer.bind_to_storage_buffer(AUX_BOUNDS_BINDING)
        _set(sh, "num_strands", st.num_strands)
        if integrate:
            self._integrate_uniforms(sh, st, h)
        _set(sh, "num_colliders", st.num_colliders)
        _set(sh, "head", _mat4(st.head))
        _set(sh, "local_stiffness", iteration_stiffness(s.local_shape_stiffness, s.shape_iterations))
        _set(sh, "bending_stiffness", iteration_stiffness(s.bending_stiffness, s.shape_iterations))
        _set(sh, "iterations", s.shape_iterations)
        _set(sh, "dt", h)
        _set(sh, "dftl_damping", s.dftl_damping)
        _set(sh, "max_speed", s.max_speed)
        if guard:
            self._guard_uniforms(sh, st)
        self._bind_sdfs(sh, sdfs)
        size = self.settings.solver.strand_group_size
        groups = (st.num_strands + size - 1) // size
        self._dispatch("length" if dftl else "shape", sh, groups)

    def _sweep_prims(self, st: SimState) -> int:
        """The PRIMS define of the sweeps: colliders in the buffer, 0 without a projection one."""
        if not any(isinstance(c, Collider) and c.mode == "projection" for c in self.colliders):
            return 0
        if st.collider_worlds is None:
            self.upload_colliders(st)
        return st.num_colliders

    def _sweep_sdfs(self, st: SimState) -> list:
        """(MeshSDF, world, previous world, collider) of the mesh colliders the sweeps handle."""
        meshes = [(i, c) for i, c in enumerate(c for c in self.colliders if isinstance(c, MeshCollider))]
        if not meshes:
            return []
        if st.mesh_worlds is None or len(st.mesh_worlds) != len(meshes):
            self.upload_colliders(st)
        out = []
        for i, c in meshes[:MAX_SWEEP_SDFS]:
            if c._sdf is None:
                c._sdf = MeshSDF.bake(self.ctx, c.mesh, resolution=c.resolution, padding=c.padding)
            out.append((c._sdf, st.mesh_worlds[i], st.mesh_prev_worlds[i], c))
        return out

    def _bind_sdfs(self, sh, sdfs: list) -> None:
        if not sdfs:
            return
        n = len(sdfs)

        def mats(ms):
            return np.concatenate([np.asarray(m, np.float64).T.reshape(-1) for m in ms]).astype(np.float32).tobytes()

        for j, (sdf, _, _, _) in enumerate(sdfs):
            sdf.texture.use(SDF_UNIT0 + j)
        _write(sh, "sdf_tex", np.arange(SDF_UNIT0, SDF_UNIT0 + n, dtype=np.int32).tobytes())
        _write(sh, "sdf_lo_h", np.array([[*sdf.lo, sdf.h] for sdf, _, _, _ in sdfs], np.float32).tobytes())
        _write(sh, "sdf_params", np.array([[c.margin, c.friction, 0, 0] for *_, c in sdfs], np.float32).tobytes())
        _write(sh, "sdf_world_to_local", mats(np.linalg.inv(w) for _, w, _, _ in sdfs))
        _write(sh, "sdf_local_to_world", mats(w for _, w, _, _ in sdfs))
        _write(sh, "sdf_prev_world_to_local", mats(np.linalg.inv(p) for _, _, p, _ in sdfs))

    def _pass_shape(self, st: SimState, h: float) -> bool:
        if not self._shape_on():
            return False
        self._strand_solve(st, h, shape=True, dftl=False, velocity=False, contact=False)
        return True

    def _pass_length(self, st: SimState, h: float, bounds: bool = False) -> bool:
        """The length pass; ``bounds``: also the grid friction box's reduction of the
        positions it leaves (``substep`` with ``fold_bounds``)."""
        s = self.settings
        if s.length_method == "dftl":
            fused = s.fused_strand_solve
            self._strand_solve(st, h, shape=fused and self._shape_on(), dftl=True, velocity=fused, contact=True,
                               integrate=fused and self.settings.solver.fold_integrate,
                               bounds=self._friction_grid().own_bounds if bounds else None,
                               guard=self._guard_in_length())
            return True
        spg = max(1, 64 // st.points_per_strand)
        sdfs = self._sweep_sdfs(st)
        sh = self._shader("pbd_length", SPG=spg, GROUP_SIZE=spg * st.points_per_strand,
                          PRIMS=self._sweep_prims(st), NSDF=len(sdfs))
        _set(sh, "num_strands", st.num_strands)
        _set(sh, "num_colliders", st.num_colliders)
        _set(sh, "iterations", s.pbd_iterations)
        _set(sh, "tether", int(s.long_range_attachment))
        _set(sh, "alpha_tilde", s.stretch_compliance / (h * h))
        self._bind_sdfs(sh, sdfs)
        self._dispatch("length", sh, (st.num_strands + spg - 1) // spg)
        return True

    def _pass_collide(self, st: SimState, h: float) -> bool:
        """Projection colliders after the fact (``substep`` does this inside ``length``)."""
        if not any(isinstance(c, Collider) and c.mode == "projection" for c in self.colliders):
            return False
        sh = self._shader("collide")
        _set(sh, "num_strands", st.num_strands)
        _set(sh, "num_colliders", st.num_colliders)
        self._dispatch("collide", sh, self._particle_groups(st))
        return True

    def _pass_sdf(self, st: SimState, h: float) -> bool:
        """Mesh colliders after the fact: all of them when run on its own, those beyond
        ``MAX_SWEEP_SDFS`` in ``substep`` (the sweeps of ``length`` do the others)."""
        meshes = [c for c in self.colliders if isinstance(c, MeshCollider)]
        if "sdf" not in self.folded_passes():
            meshes = meshes[MAX_SWEEP_SDFS:]
        if not meshes:
            return False
        with self._timed("sdf"):
            for c in meshes:
                if c._sdf is None:
                    c._sdf = MeshSDF.bake(self.ctx, c.mesh, resolution=c.resolution, padding=c.padding)
                c._sdf.collide(st, c.world_transform(st.head), c.margin, c.friction)
        self.ctx.memory_barrier()
        self._bind(st)
        return True

    def _pass_velocity(self, st: SimState, h: float) -> bool:
        s = self.settings
        sh = self._shader("velocity")
        _set(sh, "num_strands", st.num_strands)
        _set(sh, "dt", h)
        _set(sh, "dftl_damping", s.dftl_damping if s.length_method == "dftl" else 0.0)
        _set(sh, "max_speed", s.max_speed)
        self._dispatch("velocity", sh, self._particle_groups(st))
        return True

    def _defer_gather(self) -> bool:
        s = self.settings
        return bool(self.settings.solver.fold_gather and s.friction > 0 and not s.volume
                    and "integrate" not in self.folded_passes())

    def _guard_in_length(self) -> bool:
        s = self.settings
        return bool(self.settings.solver.fold_guard and s.nan_guard and self._fused() and not s.volume)

    def _bounds_in_length(self) -> bool:
        s = self.settings
        return bool(self.settings.solver.fold_bounds and s.friction > 0 and s.length_method == "dftl"
                    and "sdf" in self.folded_passes())

    @property
    def friction_grid(self) -> GridFriction | None:
        """The friction pass's grid once a step has built it, else None (the renderer's density
        shadows read it in place)."""
        return self._grid

    def _friction_grid(self) -> GridFriction:
        s = self.settings
        key = (s.grid_resolution, s.grid_method, tuple(sorted(self.settings.solver.grid_options.items())))
        if self._grid is None or self._grid_key != key:
            if self._deferred is not None:   # its gather needs the old grid
                self._deferred.settle()
            if self._grid is not None:
                self._grid.release()
            with phase("friction_grid"):
                self._grid = GridFriction(self.ctx, s.grid_resolution, s.grid_method,
                                          **self.settings.solver.grid_options)
            self._grid_key = key
        return self._grid

    def _pass_friction(self, st: SimState, h: float, gather: bool = True, reduced: bool = False) -> bool:
        """Grid friction; ``gather`` False defers the gather to the next integrate pass,
        ``reduced``: the length pass has reduced the positions into the grid's box (``substep``'s folds)."""
        s = self.settings
        if s.friction <= 0:
            return False
        grid = self._friction_grid()
        if self._deferred is not None:   # the splat overwrites the grid its gather needs
            self._deferred.settle()
            self._bind(st)
        with self._timed("friction"):
            bounds = grid.own_bounds
            bounds.update(st.positions, st.num_particles, reduced=reduced)
            grid.splat(st.positions, st.velocities, st.num_particles, bounds)
            if gather:
                grid.gather(st.positions, st.velocities, st.num_particles, s.friction)
        self.ctx.memory_barrier()
        if not gather:
            st.defer_gather(s.friction, lambda friction: self._gather_now(st, friction))
            self._deferred = st
        self._bind(st)
        return True

    def _gather_now(self, st: SimState, friction: float) -> None:
        """A deferred gather, run by ``SimState.settle``."""
        self._grid.gather(st.positions, st.velocities, st.num_particles, friction)
        self.ctx.memory_barrier()
        self._deferred = None

    def _pass_volume(self, st: SimState, h: float) -> bool:
        s = self.settings
        if not s.volume:
            return False
        if self._flip is None or self._flip_key != s.grid_resolution:
            self._flip = FlipVolume(self.ctx, s.grid_resolution)
            self._flip_key = s.grid_resolution
            # Chen's volume method with its target from the rest state (the groom's rest pose,
            # rigid in the head frame): the rest density per m^3, the same on every state
            self._rest_density = self._flip.measure_rest_density(st.buffers["rest_positions"], st.velocities,
                                                                 st.num_particles)
        with self._timed("volume"):
            self._flip.apply(st, h, s.flip_ratio, rest_density=self._rest_density)
        self.ctx.memory_barrier()
        self._bind(st)
        return True

    def _pass_guard(self, st: SimState, h: float) -> bool:
        """The NaN guard's own pass (nan_guard.comp)."""
        if not self.settings.nan_guard:
            return False
        spg = max(1, 64 // st.points_per_strand)
        sh = self._shader("nan_guard", SPG=spg, GROUP_SIZE=spg * st.points_per_strand)
        _set(sh, "num_strands", st.num_strands)
        _set(sh, "head", _mat4(st.head))
        self._guard_uniforms(sh, st)
        self._dispatch("guard", sh, (st.num_strands + spg - 1) // spg)
        return True

    def _guard_uniforms(self, sh, st: SimState) -> None:
        """The guard's limits (nan_guard.comp; strand_solve.comp with GUARD)."""
        _set(sh, "max_stretch", self.settings.max_stretch)
        _set(sh, "max_speed_abs", 10.0 * self.settings.max_speed)

    # ------------------------------------------------------------------ timing
    @contextmanager
    def _timed(self, name: str):
        if not self.profile:
            yield
            return
        if self._profiler is not None and hasattr(self._profiler, "section"):
            with self._profiler.section(f"sim.{name}"):
                yield
            return
        q = self.ctx.query(time=True)
        with q:
            yield
        self._timer.queries.setdefault(name, []).append(q)
        if len(self._timer.queries[name]) > 64:
            self._collect_times()

    def _collect_times(self) -> None:
        for name, qs in self._timer.queries.items():
            tot = self._timer.totals.setdefault(name, [0.0, 0])
            for q in qs:
                tot[0] += q.elapsed / 1e6
                tot[1] += 1
        self._timer.queries = {}

    def pass_times(self) -> dict:
        """Pass name -> mean GPU milliseconds per dispatch (needs ``profile=True``), every step
        issued so far counted (a GPU's timer results arrive a frame or two late: this waits)."""
        if self._profiler is not None and hasattr(self._profiler, "means"):
            try:
                return {k.removeprefix("sim."): v for k, v in self._profiler.means(wait=True).items()
                        if k.startswith("sim.")}
            except Exception:
                pass
        self._collect_times()
        return {k: t / c for k, (t, c) in self._timer.totals.items() if c}

    # ------------------------------------------------------------------ outputs
    def positions(self, state: SimState | None = None) -> np.ndarray:
        """(P, 3) float32 world positions read back from the GPU."""
        return (state or self.state).positions()

    def velocities(self, state: SimState | None = None) -> np.ndarray:
        return (state or self.state).velocities()

    @property
    def friction_grid(self) -> GridFriction | None:
        """The hair-hair friction grid (``GridFriction``: mass per node in ``.grid``, its box in
        ``.bounds``) once a step has built it; None before that or with friction off. The
        renderer's density shadows read it in place."""
        return self._grid

    @property
    def nan_recoveries(self) -> int:
        """Strands the NaN guard has reset since the last reset."""
        return self.state.recoveries

    def snapshot(self, state: SimState | None = None) -> SimSnapshot:
        st = state or self.state
        names = ("positions", "prev_positions", "velocities", "corrections", "guard")
        return SimSnapshot({n: st.read(n) for n in names}, st.length_scale.copy(), st.head.copy(),
                           st.head_target.copy(), st.time, st.steps, st.accumulator,
                           None if st.collider_worlds is None else [w.copy() for w in st.collider_worlds],
                           None if st.mesh_worlds is None else [w.copy() for w in st.mesh_worlds])

    def restore(self, snap: SimSnapshot, state: SimState | None = None) -> None:
        st = state or self.state
        if len(snap.length_scale) != st.num_strands:
            raise UsageError("the snapshot is of another groom")
        if not np.array_equal(snap.length_scale, st.length_scale):
            st.length_scale = snap.length_scale.copy()
            st.upload_rest()
        for name, arr in snap.buffers.items():
            st.write(name, arr)
        st.head, st.head_target = snap.head.copy(), snap.head_target.copy()
        st.time, st.steps, st.accumulator = snap.time, snap.steps, snap.accumulator
        st.collider_worlds = None if snap.collider_worlds is None else [w.copy() for w in snap.collider_worlds]
        st.mesh_worlds = None if snap.mesh_worlds is None else [w.copy() for w in snap.mesh_worlds]
        st.mesh_prev_worlds = st.mesh_worlds

    # ------------------------------------------------------------------ invariants
    def _padded(self, st: SimState, positions=None) -> np.ndarray:
        p = st.positions() if positions is None else np.asarray(positions)
        return p.astype(np.float64).reshape(st.num_strands, st.points_per_strand, 3)

    def length_errors(self, state: SimState | None = None, positions=None) -> np.ndarray:
        """(S, N-1) |segment length - rest length| / base rest length."""
        st = state or self.state
        p = self._padded(st, positions)
        info = st.read("rest_info").reshape(st.num_strands, st.points_per_strand, 4).astype(np.float64)
        seg = np.linalg.norm(np.diff(p, axis=1), axis=2)
        base = np.maximum(info[:, 1:, 3], 1e-12)
        return np.abs(seg - info[:, 1:, 0]) / base

    def max_length_error(self, state: SimState | None = None, positions=None) -> float:
        """Largest relative segment length error (dimensionless)."""
        return float(self.length_errors(state, positions).max())

    def max_root_error(self, state: SimState | None = None, positions=None) -> float:
        """Largest distance of a pinned particle from its follicle under the head, metres."""
        st = state or self.state
        p = self._padded(st, positions).reshape(-1, 3)
        rest = st.read("rest_positions")
        pinned = rest[:, 3] == 0
        target = transform_points(st.head, rest[pinned, :3])
        return float(np.linalg.norm(p[pinned] - target, axis=1).max()) if pinned.any() else 0.0

    def max_penetration(self, state: SimState | None = None, positions=None) -> float:
        """Deepest free particle inside a primitive collider, metres (0 when none is)."""
        st = state or self.state
        p = self._padded(st, positions).reshape(-1, 3)
        free = st.read("rest_positions")[:, 3] > 0
        deepest = 0.0
        for c in self.colliders:
            if isinstance(c, Collider):
                deepest = max(deepest, float(np.max(c.depth(p[free], st.head), initial=0.0)))
        return deepest

    def kinetic_energy(self, state: SimState | None = None) -> float:
        """Sum of |dx/dt|^2 / 2 over free particles (unit mass each) for the last step's
        displacement, J/kg. (Not the velocity buffer: with DFTL it carries the s_damping
        correction, which a strand hanging at rest keeps.)"""
        st = state or self.state
        if st.last_dt <= 0:
            return 0.0
        x = st.read("positions")[:, :3].astype(np.float64)
        x0 = st.read("prev_positions")[:, :3].astype(np.float64)
        free = st.read("rest_positions")[:, 3] > 0
        return float(0.5 * (((x - x0)[free] / st.last_dt) ** 2).sum())

    def release(self) -> None:
        """Free the GPU buffers (state, friction grid, FLIP volume, timers); safe to call twice.
        Also called when the simulator is dropped or leaves a ``with`` block."""
        if not self.released_now():
            return
        self._deferred = None
        for name in ("_grid", "_flip", "_profiler"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.release()
                setattr(self, name, None)
        self.state.release()


MAX_ULP_FRACTION = 1e-2
"""float32 positions must resolve a segment to this fraction of its length: a groom farther
from the origin than that allows is refused (its lengths would be silently wrong)."""
MAX_TYPICAL_SEGMENT_M = 10.0
"""A groom whose median segment is longer than this (metres) is in other units: the simulator's
gravity, lengths and collisions are in metres, so it is refused with a hint, not simulated."""


def _check_coordinates(groom) -> None:
    """Refuse a groom so far from the origin (or so large) that float32 cannot hold its segments."""
    pts = np.asarray(groom.points)
    if not len(pts):
        return
    reach = float(np.max(np.abs(pts)))     # exact in the points' own dtype
    d = pts[1:].astype(np.float64) - pts[:-1]  # the float64 diff, without a float64 copy of all points
    seg = np.sqrt(np.einsum("ij,ij->i", d, d))
    inner = np.ones(len(seg), bool)
    inner[np.asarray(groom.offsets[1:-1]) - 1] = False      # skip the jumps between strands
    seg = seg[inner & (seg > 0)]
    typical = float(np.median(seg)) if len(seg) else 0.0
    spacing = reach * 2.0 ** -23
    if typical > MAX_TYPICAL_SEGMENT_M:
        raise UsageError(f"the groom's segments are {typical:.3g} m long (median): it is not in metres. "
                         f"Scale it (Groom.scaled, or mane.io's units=) before simulating")
    if not np.isfinite(reach) or (typical > 0 and spacing > MAX_ULP_FRACTION * typical):
        raise UsageError(f"the groom reaches {reach:.3g} m from the origin, where float32 positions are "
                         f"{spacing:.2g} m apart: too coarse for its {typical:.2g} m segments. Move it near "
                         f"the origin (Groom.translated) and check its units (metres)")


__all__ = ["Simulator", "SimSnapshot", "PASSES", "GroomError"]
