"""The render rows of the ``scale`` section (issue 14, "Speed where users need it", item 5): the
workloads users meet, each row beside the figure the issue measured (``issue_ms``) and the target
it is held to (``target_ms``); the figures, the configurations per mode, the sim rows and the
summary are ``mane.bench.scale_rows``.

    mane bench render --section scale --json     # close-ups, strand counts, crowd, sim + render, cold start
    mane bench sim --section scale --json        # 1M and 2M guides x 32, full solver; cold start
    mane bench render --section scale --quick    # tiny stand-ins (llvmpipe, seconds): the JSON's shape only

The timing is the render bench's ``Bench.measure`` (warm-up, frames one at a time with GPU timer
queries and a finish each, back to back, and gapless); ``measured_ms`` is its ``gpu_ms`` mean where
GPU timer queries are used, else ``frame_ms``. Rows (``bench``):

``scale_closeup``
    A close-up portrait at 1920x1080, default ``RenderSettings``: the first camera of the mode's
    list ((azimuth, distance scale of the default framing): the default view moving in, then the
    side, then the back) whose frame the hair covers at least ``want_coverage`` of (0.5; 0.7 for
    the issue's 72% figure), 100k and 1M rendered strands (1M takes 100k's camera). ``coverage``
    is measured from frames (``hair_coverage``): the share of pixels where the hair alone has HDR
    alpha > 0.5 and, with the head drawn, a hair fragment is nearer than the head.
``scale_strands``
    Rendered strands {100k, 250k, 500k, 1M, 2M} at the default framing, 1920x1080, default
    ``RenderSettings``: one groom of ``guides`` guides, ``strands_per_guide`` = strands / guides.
``scale_crowd``
    ``crowd_heads`` instances of one groom (``crowd_strands`` rendered strands each;
    ``Renderer.set_instances``: one groom's guides, a transform per head) and one merged head
    mesh, on a grid ``crowd_spacing`` m apart, framed whole, with the coverage LOD at
    ``crowd_lod_depth`` (``RenderSettings.lod_depth`` 32 rather than the default 64, whose kept
    strands need more than an H200's 2 GiB storage block; each head thinned by how the camera sees it: the expanded
    strands hold only what is kept) and without (every strand of every head expanded: refused
    where that buffer cannot be made). ``RenderScale(bench, picture_dir=DIR)`` writes the LOD
    row's last frame to ``DIR/crowd.png``.

Every other row runs with the renderer's defaults, the coverage LOD on (``lod_depth``); the rows
named in the mode's ``no_lod`` are measured again with it off (``lod_depth`` 0, key
``..._no_lod``), and those in its ``near_field`` with ``shading_options.near_field`` on (key
``..._near``). Each row's ``renderer_stats`` holds the LOD's figures (``lod_keep_fraction``,
``strands_expanded``, ``lod_depth_complexity``).
``scale_sim_render``
    The simulate + render loop: ``loop_guides`` x ``loop_points`` simulated with the sim bench's
    full solver (DFTL, shape and bending, 8 capsules, mesh SDF, grid friction) and drawn as
    ``loop_guides`` x ``loop_spg`` rendered strands every frame: GPU ms of the step and of the
    frame (GL_TIMESTAMP sections), the CPU's issue ms of each (``cpu_submit_ms``), the wall ms with
    a finish each frame, and frames back to back (``pipelined_ms``: ``measured_ms``).
``scale_cold_start``
    In a fresh child process (programs are cached per context), once per ``cold_launches``
    (``scale_rows.LAUNCHES``: the first launch after an install, its caches in new empty folders,
    then the next launch with them; the quick mode: the caches as they are): seconds from creating the
    Simulator and the Renderer to the end of the first frame and of the first steady frame
    (``scale_rows.steady``), and the first ``cold_steps`` frames' mean; ``phases``: where the
    child's seconds went (``PHASE_NOTE``; ``mane.phases``), each program's compile in
    ``phases.compile.items``.

Configurations too big for the GPU are refused before anything is built (``check_allocation`` on
the expanded strands' bytes: a skipped row naming them), those too slow for the mode's budget
are skipped with the reason.
"""
from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

from ..phases import add as add_phase
from ..phases import phase, recording, watching
from .common import Skip, stats
from .scale_rows import LAUNCH_NAMES, SCALE_CONFIG, WARM_NAME, cold_launches, cold_start, expanded_bytes, guard_bytes, issue_fields, render_measured, steady
from .scale_rows import short_count as _k

# --------------------------------------------------------------------------- coverage
def hair_coverage(ctx, settings, groom, head, camera) -> dict:
    """The hair's visible share of the frame, from rendered frames: ``coverage`` = pixels where the
    hair alone (no head) has HDR alpha > 0.5 and, with the head drawn too, a hair fragment is
    nearer than the head (the depth of hair and head below the head alone's depth). Probe frames
    at the row's size and camera, drawn by the raster units with one sample and no shadows (each
    hair fragment then blends its coverage alpha and writes its depth); also the hair alone
    (``coverage_unoccluded``: hair the head hides counted) and the head alone."""
    from ..render import Renderer

    s = settings.replace(shadows="none", msaa=1, rasterizer="hardware", oit="none")
    w, h = s.render_size
    out = {}
    for key, draw_hair, draw_head in (("both", True, True), ("head", False, True), ("hair", True, False)):
        r = Renderer(s.replace(draw_head=draw_head), ctx=ctx, profile=False)
        try:
            if draw_hair:
                r.set_strands(groom)
            r.set_head(head)
            r.render(camera)
            target = r.hdr_target()
            alpha = np.frombuffer(target.color.read(), np.float16).reshape(h, w, 4)[..., 3].astype(np.float32)
            depth = np.frombuffer(target.depth.read(), np.float32).reshape(h, w)
            out[key] = (alpha, depth.copy())
        finally:
            r.release()
    hair = out["hair"][0] > 0.5
    head = out["head"][0] > 0.5
    in_front = out["both"][1] < out["head"][1]     # head absent: its depth is the cleared 1.0
    return {"coverage": float(np.mean(hair & in_front)), "coverage_unoccluded": float(np.mean(hair)),
            "coverage_head": float(np.mean(head)),
            "coverage_how": "probe frames at the row's size and camera (raster units, one sample, no shadows): "
                            "hair alone HDR alpha > 0.5 where, with the head drawn, a hair fragment is in front "
                            "of the head"}


def _render_settings(changes: dict):
    from ..render.settings import RenderSettings

    return RenderSettings(**changes)


class _Fixed:
    """A stand-in for render_bench.Workloads: one given groom and head (the crowd, the close-up)."""

    def __init__(self, groom, head, source: str):
        self._groom, self.head, self.source = groom, head, source

    def groom(self, guides, points):
        return self._groom


def merged_mesh(meshes):
    from ..mesh import Mesh

    verts, faces, base = [], [], 0
    for m in meshes:
        verts.append(np.asarray(m.vertices, np.float32))
        faces.append(np.asarray(m.faces, np.int64) + base)
        base += len(m.vertices)
    return Mesh(np.concatenate(verts), np.concatenate(faces).astype(np.int32))


def crowd_offsets(heads: int, spacing: float) -> list:
    """``heads`` positions on a square grid in the XZ plane, ``spacing`` m apart."""
    side = int(math.ceil(math.sqrt(heads)))
    return [np.array([(i % side - (side - 1) / 2) * spacing, 0.0, -(i // side) * spacing]) for i in range(heads)]


def crowd_instances(groom, head, heads: int, spacing: float):
    """(the heads' transforms (heads, 4, 4), one merged head mesh) of a crowd of ``groom``'s
    instances (``Renderer.set_instances``)."""
    offsets = crowd_offsets(heads, spacing)
    m = merged_mesh([head.transformed(_translation(o)) for o in offsets])
    m.metadata = dict(getattr(head, "metadata", {}) or {})
    return np.stack([_translation(o) for o in offsets]), m


def _translation(t) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = t
    return m


# --------------------------------------------------------------------------- render rows
class RenderScale:
    """The render rows, timed by a ``render_bench.Bench`` (its ``measure``)."""

    def __init__(self, bench, picture_dir=None):
        self.bench = bench
        self.picture_dir = picture_dir   # the crowd's picture goes there (crowd.png)
        self.ctx = bench.ctx
        self.cfg = SCALE_CONFIG[bench.mode]
        self._found: dict = {}   # want_coverage -> the close-up camera found for it
        # the render bench's timing machinery, with this section's frames and budgets
        bench.cfg = dict(bench.cfg, warmup=self.cfg["warmup"], frames=self.cfg["frames"],
                         config_budget_s=self.cfg["config_budget_s"], total_budget_s=self.cfg["total_budget_s"])

    def _settings(self, **changes) -> dict:
        """RenderSettings changes: the defaults at this section's size."""
        return {"size": tuple(self.cfg["size"]), **self.cfg["render"], **changes}

    def _measure(self, bench: str, key: str, name: str, groom, head, source: str, settings, camera, picture=None,
                 **fields):
        b = self.bench
        work, b.work = b.work, _Fixed(groom, head, source)
        n_before = len(b.rows)
        try:
            b.measure(bench, name, guides=groom.num_strands, points=groom.uniform_count or 0,
                      settings=settings, camera=camera, picture=picture, **fields)
        finally:
            b.work = work
        row = b.rows[-1] if len(b.rows) > n_before else None
        if row is not None:
            measured, how = render_measured(row) if row["status"] == "ok" else (None, None)
            row.update(issue_fields(key, measured), measured_as=how)
        return row

    def _skip(self, bench: str, key: str, name: str, exc: Exception, **fields):
        """The row of a configuration that failed before its timing: skipped for a known reason
        (out of memory, a missing feature, the budget, a setting refused), else an error."""
        import traceback

        from ..errors import GLFeatureError, GPUMemoryError, UsageError

        known = isinstance(exc, (Skip, GPUMemoryError, GLFeatureError, UsageError))
        reason = str(exc) if isinstance(exc, Skip) else f"{type(exc).__name__}: {exc}"
        row = self.bench._skip_row(bench, name, reason, status="skipped" if known else "error", **fields)
        if not known:
            row["traceback"] = "".join(traceback.format_exception(exc, limit=5))
        row.update(issue_fields(key, None))
        return row

    def _groom(self, guides: int):
        return self.bench.work.groom(guides, self.cfg["points"])

    def closeups(self) -> None:
        cfg = self.cfg
        for key, strands, want in cfg["closeup"]:
            guides = int(cfg["guides"])
            spg = max(1, strands // guides)
            name = f"close-up {_k(strands)} strands, hair >= {want:.0%}"
            fields = dict(rendered_strands_requested=strands, want_coverage=want)
            try:
                self.bench._before_config()
                guard_bytes(self.ctx, expanded_bytes(guides * spg, cfg["points"]), f"{name}: the expanded strands")
                groom = self._groom(guides)
                head = self.bench.work.head
                s = self._settings(strands_per_guide=spg)
                scale, cov = self._closeup_camera(_render_settings(s), groom, head, want)
            except Exception as exc:   # out of memory, too slow, ...: the row says why
                self._skip("scale_closeup", key, name, exc, **fields)
                continue
            camera = (lambda c: lambda r: r.default_camera(azimuth=c[0], distance_scale=c[1], points=None))(scale)
            for k, nm, st in self._lod_variants(key, name, s):
                row = self._measure("scale_closeup", k, nm, groom, head, "default_groom", st, camera,
                                    azimuth=scale[0], distance_scale=scale[1], **fields)
                if row is not None:   # the coverage at the timed frame's size, groom and camera
                    row.update(cov, coverage_met=bool(cov["coverage"] >= want))

    def _lod_variants(self, key: str, name: str, settings: dict) -> list:
        """(key, name, settings) of a row: as it is (the coverage LOD on, the default), with the
        LOD off where the mode's ``no_lod`` names the row, and with Chiang's near field on where
        its ``near_field`` does (``shading_options.near_field``: its cost where the strands are
        wider than a pixel, which the default waits for)."""
        out = [(key, name, settings)]
        if key in self.cfg.get("no_lod", ()):
            out.append((f"{key}_no_lod", f"{name}, LOD off", dict(settings, lod_depth=0.0)))
        if key in self.cfg.get("near_field", ()):
            near = {**settings.get("shading_options", {}), "near_field": True}
            out.append((f"{key}_near", f"{name}, near field on", dict(settings, shading_options=near)))
        return out

    def _probe_renderer(self, s, groom, head):
        from ..render import Renderer

        r = Renderer(s.replace(shadows="none"), ctx=self.ctx, profile=False)
        r.set_strands(groom)
        r.set_head(head)
        return r

    def _closeup_camera(self, s, groom, head, want: float) -> tuple[tuple, dict]:
        """The first (azimuth, distance scale) of the mode's list whose frame the hair covers >= want."""
        probe = self._probe_renderer(s, groom, head)
        try:
            cams = [(c, probe.default_camera(azimuth=c[0], distance_scale=c[1], points=None))
                    for c in self.cfg["cameras"]]
        finally:
            probe.release()
        found = self._found.get(want)   # a denser groom at the same coverage: the camera found before
        if found is not None:
            cams = [(c, cam) for c, cam in cams if c == found] + [(c, cam) for c, cam in cams if c != found]
        best = None
        for c, cam in cams:
            cov = hair_coverage(self.ctx, s, groom, head, cam)
            self.bench._log(f"  camera azimuth {c[0]:g}, distance x{c[1]:g}: hair coverage {cov['coverage']:.1%} "
                            f"({cov['coverage_unoccluded']:.1%} with what the head hides)")
            if best is None or cov["coverage"] > best[1]["coverage"]:
                best = (c, cov)
            if cov["coverage"] >= want:
                self._found.setdefault(want, c)
                return c, cov
        raise Skip(f"no camera of {[list(c) for c in self.cfg['cameras']]} (azimuth, distance scale) gives hair "
                   f"coverage >= {want:.0%} (best {best[1]['coverage']:.1%} at {list(best[0])})")

    def strands(self) -> None:
        cfg = self.cfg
        guides = int(cfg["guides"])
        for key, strands in cfg["strands"]:
            spg = max(1, strands // guides)
            name = f"{_k(strands)} strands ({guides} guides x {spg}), default framing"
            fields = dict(rendered_strands_requested=strands)
            try:
                self.bench._before_config()
                guard_bytes(self.ctx, expanded_bytes(guides * spg, cfg["points"]), f"{name}: the expanded strands")
                groom = self._groom(guides)
            except Exception as exc:
                self._skip("scale_strands", key, name, exc, **fields)
                continue
            for k, nm, st in self._lod_variants(key, name, self._settings(strands_per_guide=spg)):
                self._measure("scale_strands", k, nm, groom, self.bench.work.head, "default_groom", st, None,
                              **fields)

    def crowd(self) -> None:
        cfg = self.cfg
        heads, per = int(cfg["crowd_heads"]), int(cfg["crowd_strands"])
        guides = int(cfg["guides"])
        spg = max(1, per // guides)
        fields = dict(heads=heads, strands_per_head=per, spacing_m=cfg["crowd_spacing"],
                      instancing="one groom's guides drawn at a transform per head (Renderer.set_instances); "
                                 "the heads one merged mesh")
        built = None
        for key, lod in (("crowd_lod", True), ("crowd_no_lod", False)):
            lod_depth = float(cfg["crowd_lod_depth"]) if lod else 0.0
            name = f"crowd {heads} heads x {_k(per)} strands, LOD {f'on (lod_depth {lod_depth:g})' if lod else 'off'}"
            try:
                self.bench._before_config()
                # without the LOD every strand of every head is expanded; with it at least one
                # head's (a head near the camera keeps all its strands)
                guard_bytes(self.ctx, expanded_bytes((1 if lod else heads) * guides * spg, cfg["points"]),
                            f"{name}: the expanded strands")
                if built is None:
                    groom = self._groom(guides)
                    built = (groom,) + crowd_instances(groom, self.bench.work.head, heads, float(cfg["crowd_spacing"]))
            except Exception as exc:
                self._skip("scale_crowd", key, name, exc, lod=lod, **fields)
                continue
            groom, transforms, head = built
            picture = None
            if lod and self.picture_dir is not None:
                import os

                os.makedirs(self.picture_dir, exist_ok=True)
                picture = os.path.join(str(self.picture_dir), "crowd.png")
            camera = (lambda m: lambda r: (r.set_instances(m), r.default_camera(points=None))[1])(transforms)
            self._measure("scale_crowd", key, name, groom, head, f"default_groom x {heads} (instances)",
                          self._settings(strands_per_guide=spg, lod_depth=lod_depth), camera,
                          lod=lod, picture=picture, **fields)

    # ---- simulate + render
    def sim_render(self) -> None:
        cfg, b = self.cfg, self.bench
        S, N, spg = int(cfg["loop_guides"]), int(cfg["loop_points"]), int(cfg["loop_spg"])
        name = f"simulate {_k(S)} x {N} (full solver) + render {_k(S * spg)} strands"
        fields = dict(sim_guides=S, sim_points=N, rendered_strands_requested=S * spg)
        with b._guard("scale_sim_render", name, **fields):
            b._before_config()
            guard_bytes(self.ctx, expanded_bytes(S * spg, N), f"{name}: the expanded strands")
            row = b._row("scale_sim_render", name, **fields, **self._time_loop(S, N, spg))
            row.update(issue_fields("sim_render", row["pipelined_ms"]), measured_as="pipelined_ms")
        if b.rows and b.rows[-1]["bench"] == "scale_sim_render" and b.rows[-1]["status"] != "ok":
            b.rows[-1].update(issue_fields("sim_render", None))

    def _time_loop(self, S: int, N: int, spg: int) -> dict:
        cfg, ctx, prof = self.cfg, self.ctx, self.bench.prof
        loop = Loop(ctx, S, N, spg, _render_settings(self._settings(strands_per_guide=spg)), cfg["loop_grid"],
                    cfg["loop_sdf"])
        try:
            t0 = time.perf_counter()
            loop.frame()
            ctx.finish()
            first_s = time.perf_counter() - t0
            walls = []
            for _ in range(max(1, int(cfg["warmup"]))):
                t = time.perf_counter()
                loop.frame()
                ctx.finish()
                walls.append(time.perf_counter() - t)
            per = min(walls)
            budget = float(cfg["config_budget_s"])
            if per * 6 > budget:
                raise Skip(f"too slow for the {self.bench.mode} mode's budget: a frame takes {per * 1e3:.0f} ms")
            n = max(3, min(int(cfg["loop_frames"]), int(budget / (per * 2.5))))
            prof.reset()
            sim_issue, render_issue, wall = [], [], []
            for _ in range(n):
                ctx.finish()
                t = time.perf_counter()
                with prof.section("loop.sim"):
                    loop.step()
                t1 = time.perf_counter()
                with prof.section("loop.render"):
                    loop.render()
                t2 = time.perf_counter()
                ctx.finish()
                sim_issue.append((t1 - t) * 1e3)
                render_issue.append((t2 - t1) * 1e3)
                wall.append((time.perf_counter() - t) * 1e3)
            sim_gpu = prof.samples("loop.sim", wait=True)
            render_gpu = prof.samples("loop.render", wait=True)
            ctx.finish()
            t = time.perf_counter()
            for _ in range(n):
                loop.frame()
            ctx.finish()
            pipelined = (time.perf_counter() - t) * 1e3 / n
            # the CPU's issue with no profiler section (what an application pays), a finish before each
            bare_sim, bare_render = [], []
            for _ in range(n):
                ctx.finish()
                t = time.perf_counter()
                loop.step()
                t1 = time.perf_counter()
                loop.render()
                bare_sim.append((t1 - t) * 1e3)
                bare_render.append((time.perf_counter() - t1) * 1e3)
            ctx.finish()
            info = {k: v for k, v in loop.renderer.stats().items() if k != "passes"}
            sim_ms, render_ms = stats(sim_gpu), stats(render_gpu)
            return {
                "frames_timed": n, "first_frame_s": first_s, "source": prof.source,
                "sim_gpu_ms": sim_ms, "render_gpu_ms": render_ms,
                "gpu_sum_ms": (sim_ms["mean"] + render_ms["mean"]) if sim_ms["mean"] is not None
                and render_ms["mean"] is not None else None,
                "cpu_submit_ms": {"sim": stats(bare_sim), "render": stats(bare_render),
                                  "total": stats([a + c for a, c in zip(bare_sim, bare_render)])},
                "cpu_submit_profiled_ms": {"sim": stats(sim_issue), "render": stats(render_issue),
                                           "total": stats([a + c for a, c in zip(sim_issue, render_issue)])},
                "wall_ms": stats(wall), "pipelined_ms": pipelined,
                "fps": 1e3 / pipelined if pipelined > 0 else None,
                "rendered_strands": info.get("rendered_strands"), "rendered_segments": info.get("rendered_segments"),
                "size": list(loop.renderer.settings.size), "renderer_stats": info,
                "note": "sim_gpu_ms / render_gpu_ms: GPU timer sections around Simulator.step and Renderer.render "
                        "(on software renderers the CPU wall with a finish); cpu_submit_ms: the CPU's time to "
                        "issue each with no profiler section, a finish before each step (cpu_submit_profiled_ms: "
                        "inside the timed sections); pipelined_ms: frames back to back, one finish (measured_ms)",
            }
        finally:
            loop.release()

    def cold_start(self) -> None:
        cfg, b = self.cfg, self.bench
        S, N, spg = int(cfg["loop_guides"]), int(cfg["loop_points"]), int(cfg["loop_spg"])

        def run(launch, folder, warm):
            name = (f"cold start ({LAUNCH_NAMES[launch]}{WARM_NAME if warm else ''}): simulate {_k(S)} x {N} + "
                    f"render {_k(S * spg)} strands, {cfg['cold_steps']} frames")
            fields = dict(sim_guides=S, sim_points=N, rendered_strands_requested=S * spg,
                          steps=int(cfg["cold_steps"]), launch=launch, warm_up=warm)
            n_before = len(b.rows)
            with b._guard("scale_cold_start", name, **fields):
                b._before_config()
                res = cold_start(dict(S=S, N=N, spg=spg, size=list(cfg["size"]), steps=int(cfg["cold_steps"]),
                                      grid=int(cfg["loop_grid"]), sdf=int(cfg["loop_sdf"]), render=True,
                                      render_settings=dict(cfg["render"]), warm_up=warm),
                                 timeout=max(60.0, float(cfg["total_budget_s"]) / 2), launch=launch, folder=folder)
                row = b._row("scale_cold_start", name, **fields, **res)
                row.update(issue_fields("cold_start", res.get("to_steady_s"), unit="s"), measured_as="to_steady_s")
            if len(b.rows) > n_before and "issue_key" not in b.rows[-1]:
                b.rows[-1].update(issue_fields("cold_start", None, unit="s"))

        cold_launches(run, cfg["cold_launches"], cfg["cold_warm_up"])

    def run(self) -> None:
        self.closeups()
        self.strands()
        self.crowd()
        self.sim_render()
        self.cold_start()


class Loop:
    """The simulate + render loop: the sim bench's full solver on its scalp groom, drawn with its
    procedural head (the Renderer reads the simulator's positions in place)."""

    def __init__(self, ctx, S: int, N: int, spg: int, render_settings, grid: int, sdf: int):
        """``render_settings`` None: the simulator alone (the sim's cold start)."""
        with phase("imports"):
            from ..render import Renderer
            from ..sim import Simulator, head_motion
            from . import sim_bench

        self.ctx = ctx
        with phase("head_mesh"):
            head = sim_bench.head_mesh()
        with phase("colliders"):
            colliders = sim_bench.full_solver_colliders(sdf, head)
            settings = sim_bench.full_solver_settings(grid)
        with phase("groom"):
            groom = sim_bench.scalp_groom(S, N)
        self.sim = self.renderer = None
        t = time.perf_counter()
        with phase("simulator"):
            self.sim = Simulator(groom, colliders, settings, ctx, points_per_strand=N)
        self.sim_build_s = time.perf_counter() - t
        self.render_build_s = None
        if render_settings is not None:
            t = time.perf_counter()
            with phase("renderer"):
                self.renderer = Renderer(render_settings, ctx=ctx, profile=False)
            with phase("set_strands"):
                self.renderer.set_strands(self.sim)
            with phase("set_head"):
                self.renderer.set_head(head)
                self.camera = self.renderer.default_camera(points=None)
            self.render_build_s = time.perf_counter() - t
        self.motion = head_motion.preset("nod", pivot=sim_bench.NECK_PIVOT)

    def step(self) -> None:
        m = self.motion(self.sim.state.time + self.sim.settings.dt)
        self.sim.set_head_transform(m)
        self.sim.step()
        if self.renderer is not None:
            self.renderer.set_head_transform(m)
            self.renderer.strands_changed()

    def render(self) -> None:
        self.renderer.render(self.camera)

    def frame(self) -> None:
        self.step()
        self.render()

    def release(self) -> None:
        for o in (self.renderer, self.sim):
            if o is not None:
                o.release()


# --------------------------------------------------------------------------- cold start
PHASE_NOTE = ("phases: wall seconds and counts in the child, in order: python_start (the process "
              "spawned to the run's start: the interpreter and this module's imports), imports, context, "
              "head_mesh, colliders, groom, simulator, renderer, set_strands, set_head, first_frame, "
              "to_steady (the frames after the first up to the first steady one); nested in those: compile "
              "(each program's compile + link, n programs), shader_source (reading and preprocessing their "
              "sources), sdf_bake (disk cache or bake), shading_tables (disk cache or NumPy), groom_check, "
              "rest_data (the rest state in NumPy) and state_upload (its buffers written) in the simulator, "
              "friction_grid (made in the first step); the first frame split into first_step (the "
              "simulation step's issue), first_render (the render's issue; first_passes: the seconds up to "
              "each pass's end, per pass) and first_finish (the wait for the GPU); with sync_first_frame "
              "a finish after the step and after each pass, so that the GPU's part lands in them")


def _cold_run(spec: dict) -> dict:
    """In this process: a context (timed apart), then Simulator (+ Renderer) built and ``steps``
    frames, each with a finish. Seconds from the construction's start; ``phases``: where they went
    (``PHASE_NOTE``)."""
    started = time.time()
    with recording() as rec:
        out = _cold_frames(spec)
    phases = rec.as_dict()
    if spec.get("spawned_at") is not None:
        phases = {"python_start": {"s": round(started - float(spec["spawned_at"]), 6), "n": 1}, **phases}
    ends = out["frame_ends_s"]
    first = out["first_steady_frame"]
    if first is not None and first > 0:
        phases["to_steady"] = {"s": round(ends[first] - ends[0], 6), "n": first}
    return dict(out, phases=phases, phase_note=PHASE_NOTE)


def _cold_frames(spec: dict) -> dict:
    from ..gpu import get_context

    t = time.perf_counter()
    with phase("context"):
        ctx = get_context()
    context_s = time.perf_counter() - t
    S, N, steps = int(spec["S"]), int(spec["N"]), int(spec["steps"])
    from ..render.settings import RenderSettings

    render = bool(spec.get("render", True))
    rs = RenderSettings(**{"size": tuple(spec["size"]), **spec.get("render_settings", {}),
                           "strands_per_guide": int(spec["spg"])}) if render else None
    warmed = _warm_up(ctx, spec, rs) if spec.get("warm_up") else None
    compiled = []   # the programs compiled from here on (after a warm-up: none, or what it missed)

    def count(name, seconds, item):
        if name == "compile":
            compiled.append([item, round(seconds, 6)])

    with watching(count):
        t0 = time.perf_counter()
        loop = Loop(ctx, S, N, int(spec["spg"]), rs, int(spec["grid"]), int(spec["sdf"]))
        built_s = time.perf_counter() - t0
        try:
            ends, walls = [], []
            for i in range(steps):
                t = time.perf_counter()
                if i == 0:
                    _first_frame(loop, ctx, render, bool(spec.get("sync_first_frame", False)))
                else:
                    loop.step()
                    if render:
                        loop.render()
                    ctx.finish()
                now = time.perf_counter()
                walls.append((now - t) * 1e3)
                ends.append(now - t0)
            # each scan-form site's tuner at the end (recalled from disk, probes run, medians): a
            # second launch's late probe shows here
            forms = loop.renderer.scan_forms.details() if render else {}
        finally:
            loop.release()
    return dict(context_s=context_s, warmed=warmed, compiled_after=compiled, build_s=built_s,
                sim_build_s=loop.sim_build_s, render_build_s=loop.render_build_s, frame_ends_s=[round(e, 6) for e in ends],
                scan_forms=forms, **steady(ends, walls))


def _warm_up(ctx, spec: dict, render_settings) -> dict:
    """``mane.warm_up`` for the loop's scene (its settings, colliders and head, a few guides of its
    strand length) before the loop's Simulator and Renderer are made, as an application that hides
    the compiles behind a progress line would (the CLI's commands)."""
    from ..warmup import WARM_GUIDES, warm_up
    from . import sim_bench

    head = sim_bench.head_mesh()
    N = int(spec["N"])
    return warm_up(ctx, groom=sim_bench.scalp_groom(WARM_GUIDES, N), head=head, render_settings=render_settings,
                   sim_settings=sim_bench.full_solver_settings(int(spec["grid"])),
                   colliders=sim_bench.full_solver_colliders(int(spec["sdf"]), head), points_per_strand=N,
                   render=render_settings is not None, still=False)


def _first_frame(loop, ctx, render: bool, sync: bool) -> None:
    """The cold run's first frame in phases (``PHASE_NOTE``): first_step, first_render (with each
    pass's seconds in first_passes), first_finish; ``sync``: a finish after the step and after
    each pass, so that the GPU's part lands in them rather than in first_finish."""
    with phase("first_frame"):
        with phase("first_step"):
            loop.step()
            if sync:
                ctx.finish()
        if render:
            r = loop.renderer
            last = [time.perf_counter()]

            def on_pass(name: str) -> None:
                if sync:
                    ctx.finish()
                now = time.perf_counter()
                add_phase("first_passes", now - last[0], name)
                last[0] = now

            r.on_pass = on_pass
            try:
                with phase("first_render"):
                    loop.render()
            finally:
                r.on_pass = None
        with phase("first_finish"):
            ctx.finish()


def _main(argv) -> int:
    """The cold-start child: ``python -m mane.bench.scale_bench SPEC_JSON``; one JSON line out."""
    from ..errors import GLFeatureError, GPUMemoryError

    spec = json.loads(argv[0])
    try:
        out = _cold_run(spec)
    except (GPUMemoryError, GLFeatureError, Skip) as exc:
        out = {"skip": f"{type(exc).__name__}: {exc}"}
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
