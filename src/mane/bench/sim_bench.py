"""``mane bench sim``: GPU milliseconds of the strand solver, per pass and per step.

    result = run(ctx, "default")          # the JSON object; format_text(result) for tables

Workloads are procedural (no files): S straight strands of N points growing along the
normals of a spherical scalp cap (radius 0.1 m at (0, 1.6, 0)), the head nodding. Sections:

``dftl_core``
    strands {1k, 10k, 100k} x vertices {16, 32} (quick: {256, 1k}): integrate, DFTL length,
    one sphere collider, velocity, NaN guard.
``full_solver``
    DFTL + local shape and bending + 8 capsules + a mesh SDF (64^3, of a procedural head) +
    64^3 grid friction (atomic, and raster for comparison) at 100k x 32 (quick: 256 x 16),
    with the fused strand solve (the default), then with separate passes ("... separate").
    ``targets`` compares the fused atomic one with the issue's 1.0 ms per step.

Passes that the simulator folds into another (``Simulator.folded_passes()``: shape,
collide, sdf and velocity into length with the fused strand solve) are listed with 0 ms
in ``passes_ms`` and named in ``folded_passes``; their time is in the pass doing the work.
``woodhouse``
    Woodhouse (2017) Table 5.2's categories on his workload, 242 strands x 8 particles and
    smoothed to 16, with his 25^3 voxel grid, both splat methods: strand dynamics =
    integrate + shape + length + collide (+ sdf) + velocity; clear voxels; voxel
    calculations = bounds + splat + normalise + gather.
``grid_friction``
    atomic vs raster splat at 16^3 / 32^3 / 64^3 (full: + 128^3) on the full-solver
    particles: bounds, clear, splat, normalise, gather.
``flip``
    Chen (2011) Tables 2-3: the FLIP volume pass at 16^3 / 32^3 / 64^3 on his 1750 key hairs x 6
    particles (default and full modes also 10k x 16): GPU ms and share of each stage (p2g,
    classify, divergence, pcg, gradient, g2p), PCG iterations, and ``flip_numpy`` (NumPy/SciPy,
    the same method, Jacobi PCG) on the same particles (not at 64^3 in quick mode).
``chen_shares``
    Chen Table 4: share of constraints / volume / force-velocity-position in a whole
    simulator step with the volume pass on.

Timing of a configuration: compile and warm up, then K steps three times:

1. whole step: a ``GpuProfiler`` section around ``sim.step()`` (GL_TIMESTAMP on real GPUs;
   CPU wall with ``ctx.finish()`` on software renderers) and the CPU wall time of the step
   with ``ctx.finish()`` after it; mean, median and p95 of both;
2. pipelined: K steps issued back to back, one ``finish`` at the end, wall time / K;
3. per pass: the simulator's own profiler (``Simulator(profile=True)``, sections
   ``sim.<pass>``, the names of ``PASSES``), per-pass means; the step's wall time with the
   per-pass sections on is kept too (``profiled_wall_ms``), since a timestamp pair (or on
   the CPU source a ``finish``) per pass adds overhead that can dominate tiny kernels.

A configuration that does not fit (``GPUMemoryError``), lacks a GL feature, or whose step
is too slow for the mode's time budget is recorded with ``status: "skipped"`` and a reason.
"""
from __future__ import annotations

import math
import time

import numpy as np

from .common import (title_line, BenchRows, Skip, check_sections, envelope, failures_table, fmt, peak_bandwidth, stat_of, stats, table,
                     time_each, time_pipelined)

HEAD_CENTER = np.array([0.0, 1.6, 0.0])
HEAD_RADIUS = 0.1
NECK_PIVOT = (0.0, 1.45, 0.0)
STRAND_LENGTH = 0.22
TARGET_MS = 1.0
TARGET_STRANDS, TARGET_VERTICES = 100_000, 32

MODE_CONFIG = {
    "quick": dict(core_strands=(256, 1000), core_vertices=(16, 32), full_solver=[(256, 16)],
                  woodhouse=[(242, 8), (242, 16)], woodhouse_grid=25, grid_res=(16, 32, 64),
                  flip_res=(16, 32, 64), flip_cpu_res=(16, 32), flip_workloads=[(1750, 6)],
                  chen_res=(16, 32), sdf_res=64, full_grid_res=64,
                  warmup=3, steps=8, grid_iters=5, flip_applies=2, cpu_repeats=1, budget_s=6.0),
    "default": dict(core_strands=(1000, 10_000, 100_000), core_vertices=(16, 32),
                    full_solver=[(TARGET_STRANDS, TARGET_VERTICES)],
                    woodhouse=[(242, 8), (242, 16)], woodhouse_grid=25, grid_res=(16, 32, 64),
                    flip_res=(16, 32, 64), flip_cpu_res=(16, 32, 64),
                    flip_workloads=[(1750, 6), (10_000, 16)], chen_res=(16, 32, 64), sdf_res=64,
                    full_grid_res=64, warmup=10, steps=100, grid_iters=50, flip_applies=10,
                    cpu_repeats=3, budget_s=45.0),
    "full": dict(core_strands=(1000, 10_000, 100_000), core_vertices=(16, 32),
                 full_solver=[(10_000, 32), (TARGET_STRANDS, TARGET_VERTICES)],
                 woodhouse=[(242, 8), (242, 16)], woodhouse_grid=25, grid_res=(16, 32, 64, 128),
                 flip_res=(16, 32, 64), flip_cpu_res=(16, 32, 64),
                 flip_workloads=[(1750, 6), (10_000, 16)], chen_res=(16, 32, 64), sdf_res=64,
                 full_grid_res=64, warmup=20, steps=200, grid_iters=100, flip_applies=20,
                 cpu_repeats=3, budget_s=90.0),
}

# Woodhouse Table 5.2 and Chen Table 4 categories, as simulator passes
STRAND_DYNAMICS = ("integrate", "shape", "length", "collide", "sdf", "velocity")
CHEN_CATEGORIES = {
    "solving_constraints": ("shape", "length", "collide", "sdf", "guard"),
    "volume_method": ("volume",),
    "force_velocity_position": ("integrate", "velocity"),
}
FLIP_STAGES = ("p2g", "classify", "divergence", "pcg", "gradient", "g2p")


# --------------------------------------------------------------------------- workloads
def scalp_groom(num_strands: int, points: int, length: float = STRAND_LENGTH,
                center=HEAD_CENTER, radius: float = HEAD_RADIUS, cap_degrees: float = 110.0):
    """S straight strands of N points along the normals of a spherical scalp cap (vectorised).

    Roots: a Fibonacci spiral over the cap within ``cap_degrees`` of +y, on the sphere."""
    from ..groom import Groom

    S, N = int(num_strands), int(points)
    i = np.arange(S, dtype=np.float64)
    y = 1.0 - (1.0 - math.cos(math.radians(cap_degrees))) * (i + 0.5) / S
    r = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    phi = i * (math.pi * (3.0 - math.sqrt(5.0)))
    normal = np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)
    root = np.asarray(center, np.float64) + radius * normal
    t = np.linspace(0.0, length, N)
    pts = root[:, None, :] + t[None, :, None] * normal[:, None, :]
    return Groom(pts.reshape(-1, 3).astype(np.float32), np.full(S, N, np.int32),
                 metadata={"source": "mane.bench.sim_bench.scalp_groom"})


def head_mesh(center=HEAD_CENTER, radii=(0.094, 0.097, 0.096), n_lat: int = 24, n_lon: int = 48):
    """A closed UV ellipsoid (a procedural head inside the scalp sphere)."""
    from ..mesh import Mesh

    theta = np.linspace(0.0, math.pi, n_lat + 1)[1:-1]          # rings, pole excluded
    phi = np.linspace(0.0, 2 * math.pi, n_lon, endpoint=False)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.cos(phi), np.broadcast_to(ct, (len(theta), n_lon)), st * np.sin(phi)], axis=2)
    verts = np.concatenate([[[0.0, 1.0, 0.0]], ring.reshape(-1, 3), [[0.0, -1.0, 0.0]]])
    verts = verts * np.asarray(radii) + np.asarray(center)
    top, bottom = 0, len(verts) - 1
    idx = 1 + np.arange((n_lat - 1) * n_lon).reshape(n_lat - 1, n_lon)
    nxt = np.roll(idx, -1, axis=1)
    faces = [np.stack([np.full(n_lon, top), nxt[0], idx[0]], axis=1)]
    a, b, c, d = idx[:-1], nxt[:-1], nxt[1:], idx[1:]
    faces.append(np.stack([a, b, c], axis=2).reshape(-1, 3))
    faces.append(np.stack([a, c, d], axis=2).reshape(-1, 3))
    faces.append(np.stack([np.full(n_lon, bottom), idx[-1], nxt[-1]], axis=1))
    return Mesh(verts.astype(np.float32), np.concatenate(faces).astype(np.int32))


def body_capsules():
    """8 capsules: neck, shoulders, upper arms, chest, waist, jaw (metres, Y up)."""
    from ..sim import Capsule

    spec = [((0.0, 1.38, 0.0), (0.0, 1.52, 0.0), 0.05),       # neck
            ((-0.02, 1.37, 0.0), (-0.18, 1.35, 0.0), 0.05),   # shoulders
            ((0.02, 1.37, 0.0), (0.18, 1.35, 0.0), 0.05),
            ((-0.21, 1.34, 0.0), (-0.23, 1.08, 0.0), 0.045),  # upper arms
            ((0.21, 1.34, 0.0), (0.23, 1.08, 0.0), 0.045),
            ((-0.09, 1.24, 0.0), (0.09, 1.24, 0.0), 0.11),    # chest
            ((-0.07, 1.04, 0.0), (0.07, 1.04, 0.0), 0.11),    # waist
            ((-0.04, 1.52, 0.05), (0.04, 1.52, 0.05), 0.035)]  # jaw
    return [Capsule(a=a, b=b, radius=r, friction=0.2) for a, b, r in spec]


def full_solver_colliders(sdf_resolution: int, head=None):
    """The full solver's colliders: the 8 body capsules and the head mesh's SDF (``head``:
    the mesh, default head_mesh())."""
    from ..sim import MeshCollider

    head = head_mesh() if head is None else head
    return body_capsules() + [MeshCollider(head, resolution=int(sdf_resolution), padding=0.02, margin=0.002,
                                           friction=0.2)]


def full_solver_settings(grid_resolution: int, method: str = "atomic"):
    """The full solver's SimSettings: DFTL, local shape and bending, grid friction."""
    from ..sim import SimSettings

    return SimSettings(length_method="dftl", local_shape_stiffness=0.05, bending_stiffness=0.1,
                       shape_iterations=2, global_shape_stiffness=0.01, friction=0.1,
                       grid_resolution=int(grid_resolution), grid_method=method)


def head_sphere():
    from ..sim import Sphere

    return Sphere(center=tuple(HEAD_CENTER), radius=HEAD_RADIUS * 0.98, friction=0.2)


# --------------------------------------------------------------------------- timing helpers
class _Timed:
    """A proxy of a ComputeShader / VertexArray whose run / render is a profiler section."""

    def __init__(self, obj, prof, name: str):
        self._obj, self._prof, self._name = obj, prof, name

    def run(self, *args, **kwargs):
        with self._prof.section(self._name):
            return self._obj.run(*args, **kwargs)

    def render(self, *args, **kwargs):
        with self._prof.section(self._name):
            return self._obj.render(*args, **kwargs)

    def __getitem__(self, key):
        return self._obj[key]

    def __getattr__(self, name):
        return getattr(self._obj, name)


class Bench(BenchRows):
    """Runs the sections of one mode and collects rows."""

    def __init__(self, ctx, mode: str = "default", progress=None):
        self._start(ctx, mode, MODE_CONFIG, progress)
        self.cfg = MODE_CONFIG[mode]
        self.pass_names_seen: set[str] = set()

    # ---- helpers (_log, _row, _guard: BenchRows)
    def _simulator(self, S: int, N: int, colliders, settings):
        from ..sim import Simulator

        groom = scalp_groom(S, N)
        sim = Simulator(groom, colliders, settings, self.ctx, points_per_strand=N, profile=1)   # every step
        sim.profile = False  # per-pass sections only in phase 3
        return sim

    def _motion_step(self, sim, motion) -> None:
        st = sim.state
        sim.set_head_transform(motion(st.time + sim.settings.dt))
        sim.step()

    def _time_sim(self, sim, *, steps: int | None = None, warmup: int | None = None) -> dict:
        """Warm up, then the three timing phases (module doc). Returns the timing fields."""
        from ..sim import PASSES, head_motion

        ctx = self.ctx
        K = int(steps or self.cfg["steps"])
        W = int(warmup if warmup is not None else self.cfg["warmup"])
        budget = float(self.cfg["budget_s"])
        motion = head_motion.preset("nod", pivot=NECK_PIVOT)
        t0 = time.perf_counter()
        self._motion_step(sim, motion)   # compiles the kernels, bakes the SDF, builds the grids
        ctx.finish()
        first_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        done = 0
        while done < max(W, 1):   # W steps, or fewer when they eat a quarter of the budget
            self._motion_step(sim, motion)
            ctx.finish()
            done += 1
            if time.perf_counter() - t0 > budget / 4:
                break
        per_step = (time.perf_counter() - t0) / done
        # three phases of K steps (the per-pass one is slower); fit them in the budget
        if per_step * 9 > budget:
            raise Skip(f"too slow for the {self.mode} mode's budget: a step takes {per_step * 1e3:.0f} ms "
                       f"(budget {budget:.0f} s for 3 phases of at least 3 steps)")
        K_eff = max(3, min(K, int(budget / (per_step * 3.5))))

        # 1. whole step, one at a time
        prof = self.prof
        prof.reset()
        step = lambda: self._motion_step(sim, motion)  # noqa: E731
        wall, submit = time_each(ctx, step, K_eff, prof, "step")
        gpu = prof.samples("step", wait=True)

        # 2. pipelined
        pipelined = time_pipelined(ctx, step, K_eff)

        # 3. per pass
        inner = getattr(sim, "_profiler", None)
        if inner is not None:
            inner.reset()
        sim.profile = True
        try:
            profiled, _ = time_each(ctx, step, K_eff)
        finally:
            sim.profile = False
        if inner is not None and hasattr(inner, "flush"):
            inner.flush()
        passes = dict(sim.pass_times())
        # passes another one does the work of (Simulator.folded_passes: the fused strand
        # solve, collisions inside the length sweep) are listed with 0 ms
        folded = dict(sim.folded_passes()) if hasattr(sim, "folded_passes") else {}
        for name in folded:
            passes.setdefault(name, 0.0)
        self.pass_names_seen.update(passes)
        ordered = {name: passes[name] for name in PASSES if name in passes}
        ordered.update({k: v for k, v in passes.items() if k not in ordered})
        gpu_stats, wall_stats = stats(gpu), stats(wall)
        return {
            "steps_timed": K_eff,
            "warmup_steps": done,
            "first_step_s": first_s,
            "step_ms": gpu_stats,
            "step_source": prof.source,
            "wall_ms": wall_stats,
            "submit_ms": stats(submit),
            "pipelined_ms": pipelined,
            "profiled_wall_ms": stats(profiled),
            "passes_ms": ordered,
            "folded_passes": folded,
            "strand_solve": ("fused" if folded.get("shape") == "length" else "separate"),
            "pass_source": getattr(inner, "source", "moderngl time query"),
            "kernel_sum_ms": sum(ordered.values()) if ordered else None,
            # the step's GPU time that no pass section holds (collider upload, gaps between
            # dispatches): step_ms.mean = kernel_sum_ms + other_ms
            "other_ms": (gpu_stats["mean"] - sum(ordered.values())) if ordered and gpu_stats.get("mean") else None,
            "nan_recoveries": sim.nan_recoveries,
            "warnings": list(sim.warnings),
            "solver_config": solver_config(sim),
        }

    # ------------------------------------------------------------------ sections
    def dftl_core(self) -> None:
        from ..sim import SimSettings

        for N in self.cfg["core_vertices"]:
            for S in self.cfg["core_strands"]:
                name = f"{S}x{N}"
                fields = dict(strands=S, vertices=N, particles=S * N)
                sim = None
                with self._guard("dftl_core", name, **fields):
                    sim = self._simulator(S, N, [head_sphere()], SimSettings(length_method="dftl"))
                    row = self._row("dftl_core", name, **fields, **self._time_sim(sim))
                    integrate_ms = row["passes_ms"].get("integrate")
                    if not integrate_ms and row["folded_passes"].get("integrate"):
                        # folded into the fused strand solve: its own kernel, by itself, for the
                        # bandwidth figure (run after the timed steps; it moves the state on)
                        integrate_ms = row["integrate_kernel_ms"] = self._pass_alone_ms(sim, "integrate")
                    row["integrate_bandwidth"] = integrate_bandwidth(sim.state, integrate_ms, self._renderer())
                if sim is not None:
                    sim.release()

    def _pass_alone_ms(self, sim, name: str) -> float | None:
        """Mean GPU ms of one pass's own kernel run by itself (``Simulator.run_pass``)."""
        n = max(3, min(int(self.cfg["steps"]), 50))
        sim.run_pass(name)   # compiles
        self.ctx.finish()
        key = f"alone.{name}"
        for _ in range(n):
            with self.prof.section(key):
                sim.run_pass(name)
        got = self.prof.samples(key, wait=True)
        return sum(got) / len(got) if got else None

    def _full_settings(self, method: str):
        return full_solver_settings(self.cfg["full_grid_res"], method)

    def full_solver(self) -> None:
        """The issue's target configuration, then grid friction atomic vs raster on its particles."""
        from dataclasses import replace

        for S, N in self.cfg["full_solver"]:
            sim = None
            last = (S, N) == tuple(self.cfg["full_solver"][-1])
            # the fused strand solve with both grid methods, then the separate passes
            for method, fused in self.FULL_VARIANTS:
                name = f"{S}x{N} {method}" + ("" if fused else " separate")
                fields = dict(strands=S, vertices=N, particles=S * N, grid_method=method,
                              grid_resolution=self.cfg["full_grid_res"], sdf_resolution=self.cfg["sdf_res"],
                              capsules=8)
                settings = replace(self._full_settings(method), fused_strand_solve=fused)
                with self._guard("full_solver", name, **fields):
                    if sim is None:
                        sim = self._simulator(S, N, full_solver_colliders(self.cfg["sdf_res"]), settings)
                    else:
                        sim.settings = settings
                    self._row("full_solver", name, **fields, **self._time_sim(sim))
            if sim is not None:
                if last:
                    self.grid_friction(sim.state)
                sim.release()

    FULL_VARIANTS = (("atomic", True), ("raster", True), ("atomic", False))
    """full_solver's configurations: (grid method, fused strand solve)."""
    GRID_VARIANTS = (("atomic", {}), ("atomic", {"splat": "direct"}), ("raster", {}))
    """grid_friction's splats: (method, GridFriction options)."""

    # stages of GridFriction, in the order the grid friction table shows them
    GRID_STAGES = ("bounds", "bin", "splat", "normalise", "gather")

    def _grid_breakdown(self, state, resolution: int, method: str, iters: int, **options) -> dict:
        """bounds / bin / splat / normalise / gather / other of one GridFriction, ms (means over iters).

        Every dispatch (draw) is its own profiler section, through GridFriction's ``_run`` hook;
        the binned splat's count, scan and scatter are summed as ``bin``. ``total`` is one section
        around the whole friction step, and ``other`` = total - the stages: barriers and state
        changes between dispatches (for raster, also the framebuffer clear and blend set-up), so
        the columns add up to ``total``. ``clear`` is timed separately: an explicit clear of the
        voxels (raster: the FBO clear that ``splat`` does first; atomic: a clear dispatch on the
        accumulator, which mane otherwise fuses into normalise).
        """
        from ..gpu.bounds import GridBounds
        from ..sim.grid_friction import GridFriction

        ctx, prof = self.ctx, self.prof
        gf = GridFriction(ctx, resolution, method, **options)
        bounds = GridBounds(ctx)   # GridFriction's own defaults: relative margin 0.05, cubic
        pos, vel, n = state.positions, state.velocities, state.num_particles
        stage_of = {"count": "bin", "scan": "bin", "scatter": "bin"}
        plain_run, plain_render = gf._run, gf._run_render
        try:
            gf.apply(pos, vel, n, 0.1)   # compile
            ctx.finish()
            samples: dict[str, list] = {}

            def timed_run(stage, shader, groups_x):
                with prof.section(f"grid.{stage}"):
                    plain_run(stage, shader, groups_x)

            def timed_render(mode, vertices):
                with prof.section("grid.splat"):
                    plain_render(mode, vertices)

            gf._run, gf._run_render = timed_run, timed_render
            prof.reset()
            wall = []
            for _ in range(iters):
                ctx.finish()
                t = time.perf_counter()
                with prof.section("grid.total"):
                    with prof.section("grid.bounds"):
                        bounds.update(pos, n)
                    gf.splat(pos, vel, n, bounds)
                    gf.gather(pos, vel, n, 0.1)
                ctx.finish()
                wall.append((time.perf_counter() - t) * 1e3)
                # clear voxels by itself (raster: the FBO clear that splat does first;
                # atomic: a GPU clear of the accumulator, which mane fuses into normalise)
                with prof.section("grid.clear_voxels"):
                    if method == "raster":
                        with ctx.scope(gf._fbo):
                            gf._fbo.clear(0.0, 0.0, 0.0, 0.0)
                    else:
                        gf.clear_accumulator()
            prof.flush()
            for name in prof.names():
                if name.startswith("grid."):
                    samples[name[5:]] = prof.samples(name)
        finally:
            gf._run, gf._run_render = plain_run, plain_render
            info = {"float_atomics": gf.float_atomics, "splat_schedule": gf.splat_schedule,
                    "vertex_layer": gf.vertex_layer}
            gf.release()
            bounds.release()
        per_iter = {k: sum(v) / iters for k, v in samples.items()}   # sums of a stage's dispatches
        out = {k: None for k in self.GRID_STAGES}
        for stage, ms in per_iter.items():
            key = stage_of.get(stage, stage)
            if key in out:
                out[key] = (out[key] or 0.0) + ms
        if method == "raster" or gf.splat_schedule == "direct":
            out["bin"] = 0.0
        out["total"] = per_iter.get("total")
        out["clear"] = per_iter.get("clear_voxels")
        parts = [out[k] for k in self.GRID_STAGES]
        if out["total"] is not None and all(p is not None for p in parts):
            out["other"] = max(0.0, out["total"] - sum(parts))
            out["stage_sum"] = sum(parts)
        else:
            out["other"] = out["stage_sum"] = None
        out["wall_ms"] = stats(wall)
        # Woodhouse's "voxel calculations": the friction step less the voxel clear he counts apart
        # (raster: the FBO clear inside splat; atomic: none, it is fused into normalise)
        clear_inside = (out["clear"] or 0.0) if method == "raster" else 0.0
        out["voxel_calculations"] = None if out["total"] is None else max(0.0, out["total"] - clear_inside)
        out["clear_fused_into_normalise"] = method == "atomic"
        out.update(info)
        return out

    def grid_friction(self, state) -> None:
        S, N = state.num_strands, state.points_per_strand
        for R in self.cfg["grid_res"]:
            for method, options in self.GRID_VARIANTS:
                label = " ".join([method] + [str(v) if k == "splat" else (k if v is True else f"{k}={v}")
                                             for k, v in options.items()])
                name = f"{R}^3 {label} ({S}x{N})"
                fields = dict(resolution=R, method=method, variant=label, strands=S, vertices=N, particles=S * N)
                with self._guard("grid_friction", name, **fields):
                    self._row("grid_friction", name, **fields,
                              **self._grid_breakdown(state, R, method, self.cfg["grid_iters"], **options))

    def woodhouse(self) -> None:
        from ..sim import SimSettings

        R = self.cfg["woodhouse_grid"]
        for S, N in self.cfg["woodhouse"]:
            for method in ("atomic", "raster"):
                name = f"{S}x{N} {method} {R}^3"
                fields = dict(strands=S, vertices=N, particles=S * N, grid_method=method, grid_resolution=R)
                sim = None
                with self._guard("woodhouse", name, **fields):
                    settings = SimSettings(length_method="dftl", local_shape_stiffness=0.05, friction=0.1,
                                           grid_resolution=R, grid_method=method)
                    sim = self._simulator(S, N, [head_sphere()], settings)
                    timing = self._time_sim(sim)
                    grid = self._grid_breakdown(sim.state, R, method, self.cfg["grid_iters"])
                    passes = timing["passes_ms"]
                    cats = {
                        "strand_dynamics": sum(passes.get(p, 0.0) for p in STRAND_DYNAMICS),
                        "clear_voxels": grid["clear"],
                        "voxel_calculations": grid["voxel_calculations"],
                        "friction_pass": passes.get("friction"),
                    }
                    self._row("woodhouse", name, **fields, categories_ms=cats, grid_ms=grid, **timing)
                if sim is not None:
                    sim.release()

    def flip(self) -> None:
        from ..sim import SimSettings
        from ..sim.flip import FlipVolume
        from ..sim.flip_cpu import flip_numpy

        for S, N in self.cfg["flip_workloads"]:
            sim = pos = vel = None
            try:
                with self._guard("flip", f"setup {S}x{N}", strands=S, vertices=N):
                    sim = self._simulator(S, N, [head_sphere()], SimSettings(length_method="dftl"))
                    for _ in range(10):
                        sim.step()
                    st = sim.state
                    pos = st.read("positions")
                    vel = flip_velocities(pos)
                if sim is None or pos is None:
                    continue
                dt = sim.settings.dt
                for R in self.cfg["flip_res"]:
                    name = f"{R}^3 ({S}x{N})"
                    fields = dict(resolution=R, strands=S, vertices=N, particles=S * N)
                    with self._guard("flip", name, **fields):
                        row = self._row("flip", name, **fields,
                                        **self._flip_gpu(FlipVolume, st, vel, dt, R))
                        if R in self.cfg["flip_cpu_res"]:
                            secs, iters = [], None
                            for _ in range(self.cfg["cpu_repeats"]):
                                _, info = flip_numpy(pos, vel, dt, resolution=R, flip_ratio=0.95)
                                secs.append(info["seconds"] * 1e3)
                                iters = info["iterations"]
                            cpu = stats(secs)
                            row["cpu_ms"] = cpu
                            row["cpu_pcg_iterations"] = iters
                            gpu_ms = row["apply_ms"]["mean"]
                            row["speedup"] = (cpu["median"] / gpu_ms) if gpu_ms else None
                        else:
                            row["cpu_ms"] = None
                            row["cpu_skipped"] = f"not run in {self.mode} mode"
            finally:
                if sim is not None:
                    sim.release()

    def _flip_gpu(self, FlipVolume, st, vel, dt: float, R: int) -> dict:
        ctx, prof = self.ctx, self.prof
        flip = FlipVolume(ctx, R)
        try:
            stage = {id(flip._p2g): "p2g", id(flip._faces): "classify", id(flip._divergence): "divergence",
                     id(flip._reduce["INIT"]): "pcg", id(flip._matvec): "pcg", id(flip._update): "pcg",
                     id(flip._direction): "pcg", id(flip._reduce["ALPHA"]): "pcg",
                     id(flip._reduce["BETA"]): "pcg", id(flip._gradient): "gradient", id(flip._g2p): "g2p"}
            for sh in flip._classify.values():
                stage[id(sh)] = "classify"
            plain_run = flip._run

            def timed_run(shader, count, local):
                name = stage.get(id(shader), "other")
                with prof.section(name):
                    plain_run(shader, count, local)

            st.write("velocities", vel)
            flip.apply(st, dt, 0.95)            # compile
            ctx.finish()
            applies = int(self.cfg["flip_applies"])
            t = time.perf_counter()
            st.write("velocities", vel)
            flip.apply(st, dt, 0.95)
            ctx.finish()
            one = time.perf_counter() - t
            budget = float(self.cfg["budget_s"])
            if one * 2 > budget:
                applies = 1
            else:
                applies = max(1, min(applies, int(budget / (2.5 * one))))
            prof.reset()
            wall, iters, residual = [], [], []
            for _ in range(applies):
                st.write("velocities", vel)
                ctx.finish()
                t = time.perf_counter()
                with prof.section("apply"):
                    info = flip.apply(st, dt, 0.95)
                ctx.finish()
                wall.append((time.perf_counter() - t) * 1e3)
                iters.append(info["iterations"])
                residual.append(info["residual"])
            apply_gpu = prof.samples("apply", wait=True)
            # per stage: every kernel a section (sums per apply)
            prof.reset()
            flip._run = timed_run
            staged_wall = []
            for _ in range(applies):
                st.write("velocities", vel)
                ctx.finish()
                t = time.perf_counter()
                flip.apply(st, dt, 0.95)
                ctx.finish()
                staged_wall.append((time.perf_counter() - t) * 1e3)
            flip._run = plain_run
            prof.flush()
            stages = {s: sum(prof.samples(s)) / applies for s in FLIP_STAGES}
            if prof.samples("other"):   # a kernel this benchmark does not know (FlipVolume changed)
                stages["other"] = sum(prof.samples("other")) / applies
            total = sum(stages.values())
            share = {s: (v / total if total > 0 else None) for s, v in stages.items()}
        finally:
            flip.release()
        return {"applies_timed": applies, "apply_ms": stats(apply_gpu), "apply_source": prof.source,
                "wall_ms": stats(wall), "staged_wall_ms": stats(staged_wall), "stages_ms": stages,
                "stage_share": share, "kernel_sum_ms": total, "pcg_iterations": float(np.mean(iters)),
                "residual": float(np.max(residual))}

    def chen_shares(self) -> None:
        from ..sim import SimSettings

        S, N = self.cfg["flip_workloads"][0]
        for R in self.cfg["chen_res"]:
            name = f"{R}^3 ({S}x{N})"
            fields = dict(resolution=R, strands=S, vertices=N, particles=S * N)
            sim = None
            with self._guard("chen_shares", name, **fields):
                settings = SimSettings(length_method="dftl", local_shape_stiffness=0.05, volume=True,
                                       grid_resolution=R)
                sim = self._simulator(S, N, [head_sphere()], settings)
                timing = self._time_sim(sim, steps=max(3, self.cfg["steps"] // 4))
                passes = timing["passes_ms"]
                cats = {c: sum(passes.get(p, 0.0) for p in ps) for c, ps in CHEN_CATEGORIES.items()}
                tot = sum(cats.values())
                share = {c: (v / tot if tot > 0 else None) for c, v in cats.items()}
                step = timing["step_ms"]["mean"]
                self._row("chen_shares", name, **fields, categories_ms=cats, share=share,
                          fps=(1e3 / step if step else None), **timing)
            if sim is not None:
                sim.release()

    def _renderer(self) -> str:
        return str(self.ctx.info.get("GL_RENDERER", "unknown"))

    SECTIONS = ("dftl_core", "full_solver", "woodhouse", "flip", "chen_shares")
    EXTRA_SECTIONS = ("scale",)
    """Run only when named (``mane bench sim --section scale``): issue 14's rows (scale_rows)."""

    def scale(self) -> None:
        from .scale_rows import sim_rows

        sim_rows(self, lambda: full_solver_colliders(self.cfg["sdf_res"]))

    def run_all(self, sections=None) -> None:
        """Every section, or those named (``full_solver`` includes ``grid_friction``)."""
        check_sections("sim bench", sections, self.SECTIONS + self.EXTRA_SECTIONS)
        for name in sections or self.SECTIONS:
            getattr(self, name)()


def solver_config(sim) -> dict:
    """The simulator's kernel choices (``SimSettings.solver``) that a row was measured with."""
    from dataclasses import asdict

    return {k: (dict(v) if isinstance(v, dict) else v) for k, v in asdict(sim.settings.solver).items()}


# --------------------------------------------------------------------------- analysis
def flip_velocities(pos: np.ndarray, seed: int = 0) -> np.ndarray:
    """(P, 4) float32 velocities with divergence for the FLIP benchmark: a swirl about the
    head's vertical axis, an outward push and a little noise; w = 0."""
    rng = np.random.default_rng(seed)
    x = pos[:, :3].astype(np.float64) - HEAD_CENTER
    v = np.zeros((len(pos), 4), np.float32)
    v[:, 0] = -1.5 * x[:, 2] + 2.0 * x[:, 0]
    v[:, 1] = -0.3 + 2.0 * x[:, 1]
    v[:, 2] = 1.5 * x[:, 0] + 2.0 * x[:, 2]
    v[:, :3] += rng.normal(0.0, 0.05, (len(pos), 3))
    v[pos[:, 3] == 0, :3] = 0.0
    return v


def integrate_bytes(state) -> dict:
    """Bytes the integrate kernel reads and writes in one step (vec4 buffers, 16 B each).

    Free particle: reads positions, velocities, rest_positions; writes prev_positions,
    positions (80 B). Pinned particle: reads rest_positions, positions; writes
    prev_positions, positions (64 B). The collider array and uniforms (a few hundred bytes,
    cached) are left out."""
    pinned = int(np.count_nonzero(np.asarray(state.inv_mass) == 0))
    free = int(state.num_particles) - pinned
    read = free * 3 * 16 + pinned * 2 * 16
    written = (free + pinned) * 2 * 16
    return {"read": read, "written": written, "total": read + written, "free_particles": free,
            "pinned_particles": pinned}


def integrate_bandwidth(state, integrate_ms: float | None, renderer: str) -> dict:
    b = integrate_bytes(state)
    peak, key = peak_bandwidth(renderer)
    achieved = b["total"] / (integrate_ms * 1e-3) if integrate_ms and integrate_ms > 0 else None
    return {"kernel": "integrate", "bytes_per_step": b["total"], "bytes": b, "time_ms": integrate_ms,
            "achieved_GBps": None if achieved is None else achieved / 1e9,
            "peak_GBps": None if peak is None else peak / 1e9, "peak_model": key,
            "fraction_of_peak": (achieved / peak) if (achieved is not None and peak) else None}


def _targets(rows: list[dict], mode: str) -> dict:
    full = [r for r in rows if r["bench"] == "full_solver" and r.get("grid_method") == "atomic"
            and not r["name"].endswith(" separate")]
    at_target = [r for r in full if r.get("strands") == TARGET_STRANDS and r.get("vertices") == TARGET_VERTICES]
    out = {"full_solver_100k_x32_ms": None, "target_ms": TARGET_MS, "met": False,
           "metric": "time per step of steps run back to back (pipelined: the wall clock of K steps "
                     "and one ctx.finish(), over K): what a running simulation pays per step, GPU idle "
                     "included. A step timed alone (step_alone_ms: GL_TIMESTAMP pair around "
                     "Simulator.step) also holds the GPU's wait for Python to issue its passes",
           "configuration": "DFTL + local shape & bending + 8 capsules + mesh SDF + 64^3 grid friction (atomic)"}
    if at_target:
        r = at_target[-1]
        if r["status"] == "ok":
            v = r["pipelined_ms"]
            out.update(full_solver_100k_x32_ms=v, met=bool(v is not None and v <= TARGET_MS),
                       step_alone_ms=r["step_ms"]["mean"],
                       median_ms=r["step_ms"]["median"], p95_ms=r["step_ms"]["p95"],
                       wall_ms=r["wall_ms"]["mean"], pipelined_ms=r["pipelined_ms"],
                       kernel_sum_ms=r["kernel_sum_ms"], cpu_submit_ms=r["submit_ms"]["mean"],
                       source=r["step_source"])
            ks, sub = r["kernel_sum_ms"], r["submit_ms"]["mean"]
            out["met_by_kernels"] = bool(ks is not None and ks <= TARGET_MS)
            if ks is not None and sub is not None:
                out["likely_bound"] = ("cpu: issuing the step's passes (Python + driver) takes longer than "
                                       "the kernels run" if sub > ks else "gpu")
        else:
            out["note"] = f"the 100k x 32 configuration was {r['status']}: {r['reason']}"
    else:
        measured = [r for r in full if r["status"] == "ok"]
        out["note"] = (f"not measured in {mode} mode (run without --quick)"
                       + (f"; measured {measured[-1]['name']}: {measured[-1]['pipelined_ms']:.3f} ms"
                          if measured else ""))
    return out


def _bandwidth(rows: list[dict]) -> dict:
    core = [r for r in rows if r["bench"] == "dftl_core" and r["status"] == "ok"
            and r.get("integrate_bandwidth", {}).get("time_ms")]
    if not core:
        return {"kernel": "integrate", "note": "no DFTL core configuration was measured"}
    best = max(core, key=lambda r: r["particles"])
    out = dict(best["integrate_bandwidth"])
    out.update(configuration=best["name"], time_source=best["pass_source"],
               bytes_counted="free particle: 3 vec4 reads (positions, velocities, rest_positions) + "
                             "2 vec4 writes (prev_positions, positions) = 80 B; pinned: 2 reads + 2 writes = 64 B",
               all_configurations={r["name"]: r["integrate_bandwidth"]["achieved_GBps"] for r in core})
    if out.get("peak_GBps") is None:
        out["note"] = ("peak DRAM bandwidth unknown for this renderer "
                       "(table: H100 SXM 3.35, H100 PCIe 2.0, H200 4.8 TB/s)")
    return out


def run(ctx, mode: str = "default", progress=None, sections=None) -> dict:
    """Every section of ``mode`` ("quick", "default", "full"), or only ``sections``
    (``Bench.SECTIONS``): the JSON object."""
    bench = Bench(ctx, mode, progress)
    cfg = bench.cfg
    bench.run_all(sections)
    from ..sim import PASSES

    unknown = sorted(bench.pass_names_seen - set(PASSES))
    timing = {
        "step_source": bench.prof.source,
        "step_source_reason": bench.prof.reason,
        "pass_source": next((r.get("pass_source") for r in bench.rows if r.get("pass_source")), None),
        "pass_names": sorted(bench.pass_names_seen),
        "pass_names_match_simulator": not unknown,
        "unknown_pass_names": unknown,
        "note": ("per-pass times are profiler sections sim.<pass> around each pass (a timestamp pair, or on "
                 "the CPU source two ctx.finish()); whole-step times are measured separately without them. "
                 "kernel_sum_ms < step_ms shows launch/barrier/CPU overhead between kernels."),
        "total_seconds": time.perf_counter() - bench.started,
    }
    settings = {k: (list(v) if isinstance(v, tuple) else v) for k, v in cfg.items()}
    settings["sim_dt"] = 1.0 / 120.0
    settings["head_motion"] = "nod about the neck, 20 deg at 0.5 Hz"
    settings["workload"] = (f"straight strands of {STRAND_LENGTH} m on a scalp cap of radius {HEAD_RADIUS} m "
                            f"(Fibonacci roots), procedural")
    settings["sections"] = list(sections) if sections else list(Bench.SECTIONS)
    if sections and "scale" in sections:
        from .scale_rows import SCALE_CONFIG

        settings["scale"] = SCALE_CONFIG[mode]
    out = {"meta": envelope(ctx, target="sim", mode=mode, settings=settings, timing=timing),
           "results": bench.rows,
           "targets": _targets(bench.rows, mode),
           "bandwidth": _bandwidth(bench.rows)}
    if sections and "scale" in sections:
        from .scale_rows import summary

        out["scale"] = summary(bench.rows)
    return out


# --------------------------------------------------------------------------- text output
def _pass(name):
    return lambda r: (r.get("passes_ms") or {}).get(name)


def format_text(result: dict) -> str:
    meta, rows = result["meta"], result["results"]
    tm = meta["timing"]
    out = [title_line(meta),
           f"timing: step {tm['step_source']}, passes {tm['pass_source']}; all times ms; "
           f"{tm['total_seconds']:.1f} s in all"]
    if meta.get("settings", {}).get("sections") == ["scale"]:   # issue 14's rows alone
        from .scale_rows import format_text as scale_text

        bad = failures_table(rows)
        return "\n".join(out + ["", scale_text(rows)] + (["", bad] if bad else []))
    ok = lambda bench: [r for r in rows if r["bench"] == bench and r["status"] == "ok"]  # noqa: E731
    step_cols = [("step mean", stat_of("step_ms", "mean"), "{:.3f}"),
                 ("median", stat_of("step_ms", "median"), "{:.3f}"),
                 ("p95", stat_of("step_ms", "p95"), "{:.3f}"), ("wall", stat_of("wall_ms", "mean"), "{:.3f}"),
                 ("pipelined", "pipelined_ms", "{:.3f}"), ("kernels", "kernel_sum_ms", "{:.3f}"),
                 ("other", "other_ms", "{:.3f}")]
    pass_cols = [(p, _pass(p), "{:.3f}") for p in ("integrate", "shape", "length", "collide", "sdf",
                                                    "velocity", "friction", "guard")]
    out.append("")
    out.append(table(ok("dftl_core"), [("config", "name", "{}"), ("particles", "particles", "{:d}")] + step_cols
                     + [c for c in pass_cols if c[0] in ("integrate", "length", "collide", "velocity", "guard")]
                     + [("integrate GB/s", lambda r: r["integrate_bandwidth"]["achieved_GBps"], "{:.1f}")],
                     title="DFTL core (integrate, DFTL, 1 sphere, velocity, guard)"))
    out.append("")
    out.append(table(ok("full_solver"), [("config", "name", "{}")] + step_cols + pass_cols,
                     title="Full solver (DFTL + shape + 8 capsules + SDF + grid friction)"))
    for r in ok("full_solver"):
        if r.get("folded_passes"):
            out.append(f"  {r['name']}: " + ", ".join(f"{k} in {v}" for k, v in r["folded_passes"].items())
                       + " (0 ms above: timed in the pass that does the work)")
    t = result["targets"]
    val = t.get("full_solver_100k_x32_ms")
    out.append(f"  target: 100k x 32 full solver <= {t['target_ms']} ms per step: "
               + (f"{val:.3f} ms -> {'MET' if t['met'] else 'NOT met'}" if val is not None
                  else f"not measured ({t.get('note', '')})"))
    if val is not None:
        out.append(f"  (kernels alone {fmt(t.get('kernel_sum_ms'))} ms, CPU issue {fmt(t.get('cpu_submit_ms'))} ms, "
                   f"wall {fmt(t.get('wall_ms'))} ms, a step timed alone {fmt(t.get('step_alone_ms'))} ms; "
                   f"bound: {t.get('likely_bound', '?')})")
    out.append("")
    out.append(table(ok("woodhouse"), [
        ("config", "name", "{}"),
        ("strand dynamics", lambda r: r["categories_ms"]["strand_dynamics"], "{:.3f}"),
        ("clear voxels", lambda r: r["categories_ms"]["clear_voxels"], "{:.3f}"),
        ("voxel calcs", lambda r: r["categories_ms"]["voxel_calculations"], "{:.3f}"),
        ("sim friction pass", lambda r: r["categories_ms"]["friction_pass"], "{:.3f}"),
        ("step mean", stat_of("step_ms", "mean"), "{:.3f}")],
        title="Woodhouse Table 5.2 categories (his 242 x 8 workload, and smoothed to 16)"))
    out.append("")
    out.append(table(ok("grid_friction"), [
        ("config", "name", "{}"), ("format", lambda r: ("float" if r.get("float_atomics") else "fixed64")
                                   if r["method"] == "atomic" else ("vs-layer" if r.get("vertex_layer") else "geom"),
                                   "{}"),
        ("bounds", "bounds", "{:.3f}"), ("bin", "bin", "{:.3f}"),
        ("splat", "splat", "{:.3f}"), ("normalise", "normalise", "{:.3f}"), ("gather", "gather", "{:.3f}"),
        ("other", "other", "{:.3f}"), ("total", "total", "{:.3f}"), ("wall", stat_of("wall_ms", "mean"), "{:.3f}"),
        ("clear", "clear", "{:.3f}")],
        title="Grid friction: atomic (binned / direct) vs raster splat; bounds + bin + splat + normalise + "
              "gather + other = total (other: barriers, state changes, raster's FBO clear); clear: an explicit "
              "voxel clear timed apart (atomic fuses it into normalise)"))
    out.append("")
    out.append(table(ok("flip"), [("config", "name", "{}"), ("GPU apply", stat_of("apply_ms", "mean"), "{:.3f}"),
                                  ("median", stat_of("apply_ms", "median"), "{:.3f}"),
                                  ("p95", stat_of("apply_ms", "p95"), "{:.3f}"),
                                  ("PCG it", "pcg_iterations", "{:.0f}")]
                     + [(s, (lambda s: lambda r: r["stage_share"][s] * 100 if r["stage_share"][s] is not None
                             else None)(s), "{:.1f}%") for s in FLIP_STAGES]
                     + [("CPU numpy", stat_of("cpu_ms", "median"), "{:.1f}"),
                        ("CPU PCG it", "cpu_pcg_iterations", "{}"),
                        ("speedup", "speedup", "{:.1f}x")],
                     title="FLIP volume (Chen Tables 2-3): GPU ms per apply, share of each stage, CPU flip_numpy"))
    out.append("")
    out.append(table(ok("chen_shares"), [("config", "name", "{}"), ("step mean", stat_of("step_ms", "mean"), "{:.3f}"),
                                         ("fps", "fps", "{:.0f}")]
                     + [(c.replace("_", " "), (lambda c: lambda r: r["share"][c] * 100 if r["share"][c] is not None
                                               else None)(c), "{:.1f}%") for c in CHEN_CATEGORIES],
                     title="Chen Table 4: share of a simulator step (volume on)"))
    bw = result["bandwidth"]
    out.append("")
    if bw.get("achieved_GBps") is not None:
        frac = bw.get("fraction_of_peak")
        out.append(f"integrate kernel DRAM bandwidth ({bw['configuration']}): {bw['bytes_per_step'] / 1e6:.1f} MB in "
                   f"{bw['time_ms']:.4f} ms = {bw['achieved_GBps']:.1f} GB/s"
                   + (f" = {frac * 100:.1f}% of {bw['peak_GBps']:.0f} GB/s ({bw['peak_model']})" if frac is not None
                      else " (peak unknown for this renderer)"))
    else:
        out.append(f"integrate kernel DRAM bandwidth: {bw.get('note', 'not measured')}")
    if result.get("scale") is not None:
        from .scale_rows import format_text as scale_text

        out += ["", scale_text(rows)]
    bad = failures_table(rows)
    if bad:
        out += ["", bad]
    if not tm["pass_names_match_simulator"]:
        out.append(f"warning: profiler sections not among the simulator's passes: {tm['unknown_pass_names']}")
    return "\n".join(out)


__all__ = ["run", "format_text", "scalp_groom", "head_mesh", "body_capsules", "integrate_bytes",
           "integrate_bandwidth", "MODE_CONFIG", "Bench"]
