"""``mane bench render``: GPU milliseconds of the strand renderer, per pass and per frame.

    result = run(ctx, "default")          # the JSON object; format_text(result) for tables

Workloads come from the procedural default scene (``mane.grooming.scene``: grooming's default
head and a groom grown on its scalp, ``grow`` when grooming has it): one groom of the most
guides a sweep needs is grown per guide point count, and each configuration renders its first
G guides (a random, evenly spread subset), each multiplied into ``strands_per_guide`` rendered
strands, tessellated to ``segments`` per strand. Sections (``bench`` in each row):

``target``
    Issue 4's target: 50,000 strands (3125 guides x 16) x 32 segments at 1920x1080,
    ``marschner_lut``, deep opacity maps (3 layers, 512^2), 4x MSAA, three lights.
    ``targets`` compares its GPU frame time with 4 ms (quick mode: a small stand-in, not compared).
``hunz_shading``
    Hunz (2016) Fig. 33: strands {10k .. 50k} x every shading model (``shading.MODELS``), his
    setup: one light, no shadows, opaque ``GL_LINES``, 656x861, 24 segments (Yuksel's
    "Straight" model: 1.2 M segments / 50k strands).
``hunz_shadows``
    Hunz Fig. 36: every shadow method ``RenderSettings`` accepts (read at run time, so new
    ones, ADSM, opacity maps, density, are picked up) x map size {128, 256, 512, 1024, 2048} x
    PCF {1, 3, 5} at 50k strands, ``marschner_lut`` (his Marschner is LUT-based), and ``none``.
``vulkan_guides`` / ``vulkan_divisions`` / ``vulkan_strands_per_guide`` / ``vulkan_pcf``
    The Vulkan project's four charts around its shipped configuration (900 guides x 12 strands,
    10 points per guide, 42 segments, 1080x720, Marschner, shadow map + opacity map, no MSAA):
    guides {100 .. 5000}, divisions {9 .. 63} (multiples of the 9 guide segments, so exact),
    strands per guide {1 .. 50}, PCF taps {1, 4, 9, 16} (pcf 1..4 per side; with the bilinear
    weights a look-up reads (pcf + 1)^2 texels).
``chen_lod``
    Chen (2011) Table 5: camera distance {0.2 .. 3.0} (multiples of the framing distance; his
    units are not given) with LOD on and off, on his scene (1750 key hairs x 16 = 28,000 hairs,
    6 points, 20 segments, Scheuermann, deep opacity maps, 2x supersampling) at 800x600 (full
    mode: his four resolutions). LOD on is recorded as skipped while ``RenderSettings`` has no
    level-of-detail switch (the row says why).
``woodhouse_msaa``
    Woodhouse (2017) Table 5.1 / 5.2: his workload (242 guides, 16 vertices = 15 segments;
    rendered strands not given: 16 per guide) with Sadeghi shading, with 4x MSAA and without,
    for deep opacity maps (his ``gpu``) and density shadows (his ``optimised_gpu``) when the
    renderer has them.

Timing of a configuration: a Renderer is built, the guides and head uploaded; W warm-up
frames (the first compiles the shaders, its wall time is ``first_frame_s``) and, on GPUs, the
frames the scan-form tuner still times its forms in (``tuner_settle_frames``, at most
SETTLE_FRAMES), then:

1. N frames, one at a time: the renderer's own profiler times every pass (``Renderer.stats``
   names: frames, shadow_map, deep_opacity, head, hair, resolve, ...), and this benchmark's
   profiler a section around the whole ``render()`` (``frame_ms``: on GPUs a GL_TIMESTAMP pair;
   it includes the framebuffer clear and any GPU idle while Python issues the next pass);
   ``passes_sum_ms`` is the per-frame sum of the passes; ``wall_ms`` the CPU wall with
   ``ctx.finish()``; ``submit_ms`` the CPU time to issue the frame (with the profiler's
   sections); ``submit_bare_ms`` the same without any profiler section (targets:
   ``cpu_submit_bare_ms``; frames played from their recording once it is confirmed,
   render/frame_replay.py; the target row's ``drawn``: the same with every frame drawn);
   targets' ``sim_render_loop``: a simulator step and a frame issued in turn
   (``Bench.sim_render_loop``);
2. pipelined: N frames back to back with the pass profiler off, one ``finish`` at the end:
   wall / N (``pipelined_ms``, ``fps``): what an application would see;
3. gapless (GPU timer queries only): N frames, each issued while a serial compute job keeps
   the GPU busy (``GpuPreload``, calibrated to 4 ms or 3x the frame's issue time), so the GPU
   runs the frame's commands back to back: ``gpu_ms`` (the frame's timestamps) and
   ``gpu_passes_ms`` are the GPU's own time, without the idle gaps Python's issuing leaves in
   ``frame_ms``. ``targets`` uses ``gpu_ms`` where there is one.

Every frame of these phases draws every pass, as when the hair or a light moves (the rows'
figures as they were before the light-space targets were reused). The target row adds
``still_hair``: phases 2 and 3 and the issue time again while the hair, head and lights are
still, as a still groom is drawn, the shadow and opacity maps and the skin's bounce reused
(mane.render.light_key), and ``orbit``: the CPU's issue and the pipelined ms while the camera
turns about the hair by ORBIT_DEGREES a frame (a user dragging the view: a new view every
frame, its uniforms and the screen-space plans made again).

On software renderers (llvmpipe) GPU timer queries are unreliable, so both profilers fall
back to CPU wall time around ``ctx.finish()`` (``meta.timing`` says which source was used).
A configuration that fails (``GPUMemoryError``, a missing GL feature, a setting the renderer
rejects, too slow for the mode's budget) is recorded with ``status`` "skipped" or "error" and a
reason; the run goes on.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..errors import UsageError
from ..gpu import microbench
from .common import title_line, BenchRows, Skip, check_sections, envelope, failures_table, fmt, stat_of, stats, table, time_each, time_pipelined

TARGET_MS = 4.0
TARGET_GUIDES, TARGET_SPG, TARGET_POINTS, TARGET_SEGMENTS = 3125, 16, 17, 32
TARGET_SIZE = (1920, 1080)
SHADING_MODELS_FALLBACK = ("kajiya_kay", "marschner", "marschner_lut", "sadeghi", "scheuermann", "karis")

MODE_CONFIG = {
    "quick": dict(
        warmup=3, frames=2, config_budget_s=3.0, total_budget_s=200.0,
        target=dict(guides=16, size=(320, 240)),
        hunz_size=(320, 240), hunz_strands=(1024, 2048), hunz_shadow_strands=256,
        shadow_sizes=(128, 512), shadow_pcf=(1, 3),
        vulkan_size=(320, 240), vulkan_base_guides=25, vulkan_guides=(12, 25, 50),
        vulkan_divisions=(9, 27, 63), vulkan_spg=(1, 4, 8), vulkan_pcf_taps=(1, 4, 9, 16), vulkan_base_spg=8,
        chen_guides=25, chen_sizes=[(320, 240)], chen_distances=(0.4, 1.0, 3.0),
        woodhouse_size=(320, 240), woodhouse_spg=1),
    "default": dict(
        warmup=3, frames=30, config_budget_s=4.0, total_budget_s=210.0,
        target=dict(guides=TARGET_GUIDES, size=TARGET_SIZE),
        hunz_size=(656, 861), hunz_strands=(10_000, 20_000, 30_000, 40_000, 50_000), hunz_shadow_strands=50_000,
        shadow_sizes=(128, 256, 512, 1024, 2048), shadow_pcf=(1, 3, 5),
        vulkan_size=(1080, 720), vulkan_base_guides=900, vulkan_guides=(100, 500, 1000, 2000, 3000, 4000, 5000),
        vulkan_divisions=(9, 18, 27, 36, 45, 54, 63), vulkan_spg=(1, 5, 10, 20, 30, 40, 50),
        vulkan_pcf_taps=(1, 4, 9, 16), vulkan_base_spg=12,
        chen_guides=1750, chen_sizes=[(800, 600)], chen_distances=(0.2, 0.4, 0.6, 1.0, 1.5, 3.0),
        woodhouse_size=(1280, 720), woodhouse_spg=16),
    "full": dict(
        warmup=3, frames=100, config_budget_s=10.0, total_budget_s=1200.0,
        target=dict(guides=TARGET_GUIDES, size=TARGET_SIZE),
        hunz_size=(656, 861), hunz_strands=(10_000, 20_000, 30_000, 40_000, 50_000), hunz_shadow_strands=50_000,
        shadow_sizes=(128, 256, 512, 1024, 2048), shadow_pcf=(1, 3, 5),
        vulkan_size=(1080, 720), vulkan_base_guides=900,
        vulkan_guides=(100, 250, 500, 1000, 2000, 3000, 4000, 5000),
        vulkan_divisions=(9, 18, 27, 36, 45, 54, 63), vulkan_spg=(1, 2, 5, 10, 15, 20, 30, 40, 50),
        vulkan_pcf_taps=(1, 4, 9, 16, 25, 49), vulkan_base_spg=12,
        chen_guides=1750, chen_sizes=[(800, 600), (1024, 712), (1152, 802), (1280, 968)],
        chen_distances=(0.2, 0.4, 0.6, 1.0, 1.5, 3.0),
        woodhouse_size=(1280, 720), woodhouse_spg=16),
}

# What the seeds report, for comparison in the JSON (see ../shared/research, beside the repository).
REFERENCES = {
    "target": "Issue 4: 50,000 strands x 32 segments, 1920x1080, Marschner LUTs, deep opacity maps "
              "(3 layers, 512^2), 4x MSAA in at most 4 ms of GPU time on an H100/H200.",
    "target_rasterizer": "The target's frame with the rasteriser 'auto' did not pick (hardware raster units "
                         "or compute shaders), for comparison.",
    "hunz_shading": "Hunz 2016 Fig. 33 (GTX 960, 656x861, one light, no shadows, opaque GL_LINES): ms vs "
                    "10k-50k strands for Straight/Wavy/Curly; values only in the chart; the models "
                    "'all perform very similarly'.",
    "hunz_shadows": "Hunz 2016 Fig. 36: SM/ADSM/DOM x 128/256/512 x PCF none/3x3/5x5 (50k strands). Text: "
                    "256^2 with 3x3 PCF: DOM ~6.3 ms, ADSM ~3.3 ms; 512^2 high PCF: ADSM ~5% slower than SM; "
                    "map resolution is DOM's biggest cost.",
    "vulkan_guides": "Vulkan hair (RTX 2080), FPS read from the chart: ~1840 @100, 550 @1000, 310 @2000, "
                     "200 @3000, 160 @4000, 135 @5000 guides.",
    "vulkan_divisions": "FPS ~1000 @10, 790 @20, 600 @40, 420 @60 divisions, flat after ~64.",
    "vulkan_strands_per_guide": "FPS ~1730 @1, 620 @10, 360 @20, 255 @30, 195 @40, 150 @50 strands per guide.",
    "vulkan_pcf": "FPS ~590 @1, 545 @4, 505 @8, 420 @12, 310 @16 shadow-map samples per pixel.",
    "chen_lod": "Chen 2011 Table 5, FPS vs viewing distance (units not given) with LOD, 800x600: 25 @0.2, "
                "44 @0.4, 63 @0.6, 98 @1.0, 136.1 @1.5 and 3.0 (the simulation's cap); GTX 480.",
    "woodhouse_msaa": "Woodhouse 2017 Table 5.1/5.2, render ms with 4x MSAA / without: optimised (density "
                      "shadows) 16.55/8.16 (HD 7520G), 8.83/4.38 (HD 6670); gpu (deep opacity maps) "
                      "38.46/26.27, 15.57/10.58.",
}
SECTIONS = ("target", "target_rasterizer", "hunz_shading", "hunz_shadows", "vulkan_guides", "vulkan_divisions",
            "vulkan_strands_per_guide", "vulkan_pcf", "chen_lod", "woodhouse_msaa")


# --------------------------------------------------------------------------- settings introspection
def settings_fields() -> dict:
    """RenderSettings field name -> dataclasses.Field (whatever fields the renderer has today)."""
    from ..render.settings import RenderSettings

    return {f.name: f for f in dataclasses.fields(RenderSettings)}


def make_settings(changes: dict, required=()):
    """RenderSettings(**changes) keeping only the fields it has; a missing ``required`` field
    is a Skip. Returns (settings, dropped changes)."""
    from ..render.settings import RenderSettings

    names = settings_fields()
    missing = [k for k in required if k not in names]
    if missing:
        raise Skip(f"RenderSettings has no field {', '.join(missing)} (fields: {', '.join(names)})")
    kw = {k: v for k, v in changes.items() if k in names}
    dropped = {k: v for k, v in changes.items() if k not in names}
    try:
        return RenderSettings(**kw), dropped
    except (UsageError, ValueError, TypeError) as exc:
        raise Skip(f"the renderer rejects these settings: {exc}") from None


def settings_dict(settings) -> dict:
    out = {}
    for f in dataclasses.fields(settings):
        v = getattr(settings, f.name)
        out[f.name] = list(v) if isinstance(v, tuple) else v
    return out


def _accepts(**changes) -> bool:
    from ..render.settings import RenderSettings

    try:
        RenderSettings(**changes)
        return True
    except Exception:
        return False


def shading_models() -> list[str]:
    try:
        from ..render.shading import MODELS

        return list(MODELS)
    except Exception:
        return list(SHADING_MODELS_FALLBACK)


def shadow_methods() -> list[str]:
    """Every shadow method the renderer knows today: ``settings.SHADOWS``, any shadow registry in
    ``mane.render.passes`` (a dict or tuple whose name has SHADOW in it), checked by
    constructing RenderSettings(shadows=m). "none" first."""
    import importlib

    found: list[str] = []
    for modname in ("mane.render.settings", "mane.render.passes", "mane.render.passes.base"):
        try:
            mod = importlib.import_module(modname)
        except Exception:
            continue
        for attr in dir(mod):
            if "SHADOW" not in attr.upper() or attr.startswith("_"):
                continue
            value = getattr(mod, attr)
            if isinstance(value, dict):
                keys = list(value)
            elif isinstance(value, (tuple, list)):
                keys = list(value)
            else:
                continue
            for k in keys:
                if isinstance(k, str) and k not in found:
                    found.append(k)
    methods = [m for m in found if _accepts(shadows=m)]
    if "none" in methods:
        methods.remove("none")
        methods.insert(0, "none")
    return methods


def lod_switch() -> tuple[dict | None, dict | None, str]:
    """(changes for LOD on, changes for LOD off, how) from RenderSettings' fields, or
    (None, None, why not)."""
    from ..render.settings import RenderSettings

    names = settings_fields()
    lod = [n for n in names if "lod" in n.lower()]
    if not lod:
        return None, None, ("RenderSettings has no level-of-detail field (no field name contains 'lod'); "
                            "rendering LOD is not implemented yet")
    try:
        defaults = RenderSettings()
    except Exception as exc:  # pragma: no cover
        return None, None, f"RenderSettings() fails: {exc}"
    for n in lod:   # a bool switch
        if isinstance(getattr(defaults, n), bool):
            if _accepts(**{n: True}) and _accepts(**{n: False}):
                return {n: True}, {n: False}, f"RenderSettings.{n} True / False"
    offs, ons = ("none", "off", "disabled", "false"), ("distance", "auto", "on", "screen", "screen_space", "enabled")
    for n in lod:   # a string mode
        d = getattr(defaults, n)
        if isinstance(d, str):
            off = next((v for v in offs if _accepts(**{n: v})), None)
            on = next((v for v in ((d,) if d not in offs else ()) + ons if _accepts(**{n: v})), None)
            if off is not None and on is not None:
                return {n: on}, {n: off}, f"RenderSettings.{n} {on!r} / {off!r}"
    return None, None, f"LOD fields {lod} found, but no on/off switch recognised (bool, or a mode with 'none'/'off')"


# --------------------------------------------------------------------------- workloads
# the target frame shades with mane's default hair model (RenderSettings.shading, "chiang")
TARGET_SHADING = "chiang"
SETTLE_FRAMES = 400   # frames a row draws at most after its warm-up for the scan-form tuner to settle
ORBIT_DEGREES = 0.25   # the target row's turning camera (Bench._orbit): a slow drag of the view


class Workloads:
    """Guide grooms of the default scene, per guide point count (grown once with the most guides
    asked for; a configuration takes the first G)."""

    def __init__(self, log=None):
        self._head = None
        self._masters: dict[int, object] = {}
        self.log = log or (lambda msg: None)
        self.source = None

    @property
    def head(self):
        if self._head is None:
            from ..grooming.scene import default_head

            self._head = default_head(4)  # the 5,120-triangle bust the benchmarks were measured on
        return self._head

    def groom(self, guides: int, points: int):
        from ..grooming.scene import default_groom

        points, guides = int(points), int(guides)
        master = self._masters.get(points)
        if master is None or master.num_strands < guides:
            want = max(guides, 0 if master is None else master.num_strands)
            t = time.perf_counter()
            g = default_groom(self.head, want, points)
            if g.uniform_count != points:
                g = g.resampled(points)
            self.source = (g.metadata or {}).get("source", "?")
            self.log(f"  grew {g.num_strands} guides x {points} points ({self.source}) in "
                     f"{time.perf_counter() - t:.1f} s")
            master = self._masters[points] = g
        if master.num_strands < guides:
            raise Skip(f"the default scene gave {master.num_strands} guides, {guides} asked for")
        return master if master.num_strands == guides else master.subset(np.arange(guides))


# --------------------------------------------------------------------------- gapless GPU time
class GpuPreload(microbench.GpuPreload):
    """``mane.gpu.microbench.GpuPreload`` (a serial compute job that keeps the GPU busy while the
    CPU issues a frame, so a timestamp pair around the frame reads the GPU's own time, without
    the idle gaps Python's issuing leaves), calibrated in GPU milliseconds."""

    iterations_per_ms: float | None = None

    def calibrate(self, prof, want_ms: float = 2.0) -> float:
        """Iterations per GPU millisecond, timed with ``prof`` (a gpu-timer GpuProfiler); the CPU wall
        time bounds the search where the timer reads nothing (software renderers)."""
        iters, rate = 1 << 12, None
        while iters <= 1 << 30:
            prof.reset()
            walls, _ = time_each(self.ctx, lambda: self.dispatch(iters), 2, prof, "bench.preload")
            ms = min(prof.samples("bench.preload", wait=True) or [0.0])
            if ms >= want_ms:
                rate = iters / ms
                break
            if min(walls) >= 4 * want_ms:     # the timer reads (next to) nothing around compute
                rate = iters / min(walls)
                break
            iters *= 4 if max(ms, min(walls)) < want_ms / 8 else 2
        prof.reset()
        self.iterations_per_ms = rate if rate is not None else float(iters) / want_ms
        return self.iterations_per_ms

    def check(self, prof, busy_ms: float = 4.0) -> float:
        """GPU ms of an empty section issued right behind a busy_ms preload. Near 0 when a timestamp
        is written once the work before it is done (what the gapless phase relies on); near busy_ms
        if the GPU stamps commands as it reads them."""
        prof.reset()
        self.ctx.finish()
        self.dispatch(int(self.iterations_per_ms * busy_ms))
        with prof.section("bench.preload_check"):
            pass
        self.ctx.finish()
        ms = (prof.samples("bench.preload_check", wait=True) or [0.0])[0]
        prof.reset()
        return ms


# --------------------------------------------------------------------------- the benchmark
class Bench(BenchRows):
    skip_errors = (Skip, UsageError)
    traceback_limit = 5
    reason_limit = 400

    def __init__(self, ctx, mode: str = "default", progress=None, *, profiler_source: str | None = None):
        self._start(ctx, mode, MODE_CONFIG, progress, profiler_source=profiler_source)
        self.cfg = MODE_CONFIG[mode]
        self.profiler_source = profiler_source
        self._preload: GpuPreload | None = None
        self.preload_note: str | None = None
        self._preload_rate: float | None = None
        self.work = Workloads(self._log)
        self.pass_source = None
        self.pass_source_reason = None
        self.pass_names: list[str] = []
        self.lod = lod_switch()
        self._release_error = None
        self.loop: dict = {}     # sim_render_loop's figures (targets["sim_render_loop"])

    def _before_config(self) -> None:
        elapsed = time.perf_counter() - self.started
        if elapsed > self.cfg["total_budget_s"]:
            raise Skip(f"the {self.mode} mode's time budget ({self.cfg['total_budget_s']:.0f} s) is spent "
                       f"({elapsed:.0f} s)")

    # ------------------------------------------------------------------ one configuration
    def measure(self, bench: str, name: str, *, guides: int, points: int, settings: dict,
                required=(), lights=None, camera=None, budget_scale: float = 1.0, raster_stats: bool = False,
                picture=None, still_hair: bool = False, **fields) -> None:
        """Render one configuration and add its row (or a skipped / error row). ``raster_stats``:
        where the compute rasteriser draws, one more frame (not timed) counts its samples;
        ``picture``: a PNG path the last frame is written to (the row's ``picture``);
        ``still_hair``: the row's ``still_hair`` too (Bench._still_hair)."""
        fields = dict(guides=int(guides), guide_points=int(points),
                      strands_per_guide=settings.get("strands_per_guide"),
                      segments_requested=settings.get("segments"), **fields)
        with self._guard(bench, name, **fields):
            self._before_config()
            s, dropped = make_settings(settings, required)
            groom = self.work.groom(guides, points)
            timing = self._time(s, groom, lights, camera, budget_scale, raster_stats, picture, still_hair)
            row = self._row(bench, name, **fields, **timing)
            row["settings"] = settings_dict(s)
            if self._release_error:
                row["release_error"] = self._release_error
            if dropped:
                row["settings_not_in_renderer"] = dropped

    def _time(self, s, groom, lights, camera, budget_scale: float = 1.0, raster_stats: bool = False,
              picture=None, still_hair: bool = False) -> dict:
        from ..render import light_key

        keep = light_key.KEEP
        light_key.KEEP = False   # every pass every frame, as when the hair or a light moves (the rows since the first)
        try:
            return self._time_frames(s, groom, lights, camera, budget_scale, raster_stats, picture, still_hair)
        finally:
            light_key.KEEP = keep

    def _time_frames(self, s, groom, lights, camera, budget_scale, raster_stats, picture, still_hair) -> dict:
        from ..render import Renderer

        ctx, cfg = self.ctx, self.cfg
        W, N = int(cfg["warmup"]), int(cfg["frames"])
        budget = float(cfg["config_budget_s"]) * float(budget_scale)
        self._release_error = None
        r = Renderer(s, ctx=ctx, profile=1, profiler_source=self.profiler_source)   # every frame
        try:
            r.set_strands(groom)
            r.set_head(self.work.head)
            cam = camera(r) if camera is not None else r.default_camera(points=None)
            # warm-up: the first frame compiles the programs and builds the LUTs
            walls = [ms / 1e3 for ms in time_each(ctx, lambda: r.render(cam, lights), max(W, 1))[0]]
            first = walls[0]
            per_frame = min(walls[1:]) if len(walls) > 1 else walls[0]
            # two phases of N frames in the budget (the profiled one a little slower)
            if per_frame * 6 > budget:
                raise Skip(f"too slow for the {self.mode} mode's budget: a frame takes {per_frame * 1e3:.0f} ms "
                           f"(budget {budget:.0f} s a configuration, 2 phases of at least 3 frames)")
            N_eff = max(3, min(N, int(budget / (per_frame * 2.5))))
            # steady state: the scan-form tuner done timing its forms (GPUs; a first launch's probe
            # takes some tens of frames, drawn while it times, never played from a recording)
            settle = 0
            while r.scan_forms.probing() and settle < SETTLE_FRAMES:
                r.render(cam, lights)
                settle += 1

            # 1. one frame at a time: passes (the renderer's profiler) and the whole frame (ours)
            prof, rp = self.prof, r.profiler
            prof.reset()
            rp.reset()
            wall, submit = time_each(ctx, lambda: r.render(cam, lights), N_eff, prof, "frame")
            frame_gpu = prof.samples("frame", wait=True)
            rp.flush()
            order = [p.name for p in r.passes]
            names = [n for n in order if rp.samples(n)] + [n for n in rp.names() if n not in order and rp.samples(n)]
            per_pass = {n: rp.samples(n) for n in names}
            for n in names:
                if n not in self.pass_names:
                    self.pass_names.append(n)
            sums = []
            for i in range(N_eff):
                total = 0.0
                for n, xs in per_pass.items():
                    if n not in order:
                        continue   # a section inside a pass (hair_compute's hair_raster, ...)
                    # a pass that ran every frame adds that frame's time; one that ran on some
                    # frames only (frames: once, after an upload) adds its mean share
                    total += xs[i] if len(xs) == N_eff else sum(xs) / N_eff
                sums.append(total)
            self.pass_source, self.pass_source_reason = rp.source, rp.reason

            # 2. pipelined: back to back, no per-pass timing, one finish; and the CPU's time to
            # issue a frame with no profiler section at all (what an application pays)
            pipelined, submit_bare = self._unprofiled(r, cam, lights, N_eff)

            # 3. gapless GPU time: the GPU kept busy while the frame is issued (GPU timer queries only)
            gapless = self._gapless(r, cam, lights, N_eff, stats(submit)["mean"])
            still = self._still_hair(r, cam, lights, N_eff, stats(submit)["mean"]) if still_hair else None
            orbit = self._orbit(r, cam, lights, N_eff) if still_hair else None
            drawn = self._drawn(r, cam, lights, N_eff) if still_hair else None

            info = {k: v for k, v in r.stats().items() if k != "passes"}
            # sample_visits, sample_writes, raster_atomics (HairComputePass.count_samples): one more frame
            counts = r.get_pass("hair_compute").count_samples(cam, lights) if raster_stats and r.compute_raster else {}
            if picture is not None:
                from PIL import Image

                Image.fromarray(r.render_image(cam, lights)).save(picture)
                counts = dict(counts, picture=str(picture))
            frame_stats = stats(frame_gpu)
            gpu_mean = (gapless.get("gpu_ms") or {}).get("mean") or frame_stats["mean"]
            eye, target = np.asarray(cam.eye, float), np.asarray(cam.target, float)
            return {
                "rendered_strands": info.get("rendered_strands"),
                "rendered_segments": info.get("rendered_segments"),
                "size": list(s.size),
                "frames_timed": N_eff,
                "warmup_frames": len(walls),
                "tuner_settle_frames": settle,
                "first_frame_s": first,
                "frame_ms": frame_stats,
                "frame_source": prof.source,
                "passes_sum_ms": stats(sums),
                "passes_ms": {n: stats(xs) for n, xs in per_pass.items()},
                "pass_source": rp.source,
                "wall_ms": stats(wall),
                "submit_ms": stats(submit),
                "submit_bare_ms": stats(submit_bare),
                "pipelined_ms": pipelined,
                **gapless,
                "fps": (1e3 / pipelined) if pipelined > 0 else None,
                **({"still_hair": still} if still is not None else {}),
                **({"orbit": orbit} if orbit is not None else {}),
                **({"drawn": drawn} if drawn is not None else {}),
                "gpu_fps": (1e3 / gpu_mean) if gpu_mean else None,
                "camera_distance_m": float(np.linalg.norm(eye - target)),
                "lights": len(lights) if lights is not None else 3,
                "renderer_stats": info,
                **counts,
                "warnings": list(getattr(r, "warnings", [])),
            }
        finally:
            try:   # a failing release must not hide the measurement or the error that ended it
                r.release()
            except Exception as exc:
                self._release_error = f"{type(exc).__name__}: {exc}"
                self._log(f"  Renderer.release failed: {self._release_error}")

    def _unprofiled(self, r, cam, lights, n: int) -> tuple:
        """With the renderer's pass profiler off: (ms a frame over ``n`` back to back with one
        finish, the CPU's issue ms of ``n`` frames each between two finishes)."""
        ctx, rp = self.ctx, r.profiler
        rp.enabled = False
        try:
            pipelined = time_pipelined(ctx, lambda: r.render(cam, lights), n)
            return pipelined, time_each(ctx, lambda: r.render(cam, lights), n)[1]
        finally:
            rp.enabled = True

    def _drawn(self, r, cam, lights, n: int) -> dict:
        """The CPU's issue (between finishes, profiler off) with every frame drawn by the passes
        (frame_replay.REPLAY off): the frames above are played from their recording once it is
        confirmed, so this is the same figure without that."""
        from ..render import frame_replay

        keep, frame_replay.REPLAY = frame_replay.REPLAY, False
        try:
            return {"submit_bare_ms": stats(self._unprofiled(r, cam, lights, n)[1])}
        finally:
            frame_replay.REPLAY = keep

    def _orbit(self, r, cam, lights, n: int) -> dict:
        """The frame while the camera turns by ORBIT_DEGREES a frame about the target (the
        cameras made before the clock): the CPU's issue of ``n`` frames each between two finishes
        and ms a frame over ``n`` back to back, the profiler off."""
        warm = max(1, n // 4)   # frames turning before the clock (the turning view's plans made once)
        turn = iter([cam.orbited(ORBIT_DEGREES * (i + 1)) for i in range(warm + 2 * n)])
        rp = r.profiler
        rp.enabled = False
        try:
            for _ in range(warm):
                r.render(next(turn), lights)
            submit = time_each(self.ctx, lambda: r.render(next(turn), lights), n)[1]
            pipelined = time_pipelined(self.ctx, lambda: r.render(next(turn), lights), n)
        finally:
            rp.enabled = True
        return {"degrees_a_frame": ORBIT_DEGREES, "submit_bare_ms": stats(submit), "pipelined_ms": pipelined}

    def _still_hair(self, r, cam, lights, n: int, submit_ms) -> dict:
        """The same frame while the hair, the head and the lights are still, as a user's still
        groom is drawn: the light-space passes' targets reused (mane.render.light_key; the rows'
        own figures draw them every frame). Pipelined ms, the CPU's issue without profiler
        sections, the gapless GPU ms and the passes reused."""
        from ..render import light_key

        light_key.KEEP = True
        try:
            for _ in range(2):   # the first keeps the targets, the second reuses them
                frame = r.render(cam, lights)
            pipelined, submit_bare = self._unprofiled(r, cam, lights, n)
            gapless = self._gapless(r, cam, lights, n, submit_ms)
            return {"kept": list(frame.kept), "pipelined_ms": pipelined, "submit_bare_ms": stats(submit_bare),
                    "gpu_ms": gapless.get("gpu_ms"),
                    "gpu_passes_ms": gapless.get("gpu_passes_ms")}
        finally:
            light_key.KEEP = False

    def _gapless(self, r, cam, lights, n: int, submit_ms) -> dict:
        rp = r.profiler
        if self.prof.source != "gpu-timer" or rp.source != "gpu-timer":
            return {"gpu_ms": None, "gpu_passes_ms": None,
                    "gpu_ms_note": "only with GPU timer queries (this renderer is timed on the CPU)"}
        if self._preload is None and self.preload_note is None:
            try:
                self._preload = GpuPreload(self.ctx)
                rate = self._preload.calibrate(self.prof)
                self._preload_rate = rate
                empty = self._preload.check(self.prof)
                self._log(f"  GPU preload: {rate:.0f} iterations per GPU ms; an empty section behind 4 ms of it "
                          f"reads {empty:.3f} ms")
                if empty > 2.0:
                    raise RuntimeError(f"an empty timestamp section behind a 4 ms preload reads {empty:.2f} ms: "
                                       "timestamps do not wait for earlier work here")
            except Exception as exc:   # no compute shader, ...: the other phases stand
                self.preload_note = f"GPU preload unavailable: {type(exc).__name__}: {exc}"
                self._log(f"  {self.preload_note}")
                if self._preload is not None:
                    self._preload.release()
                self._preload = None
        if self._preload is None:
            return {"gpu_ms": None, "gpu_passes_ms": None, "gpu_ms_note": self.preload_note}
        ctx, prof, pre = self.ctx, self.prof, self._preload
        busy_ms = min(60.0, max(4.0, 3.0 * float(submit_ms or 0.0)))
        iters = int(pre.iterations_per_ms * busy_ms)
        prof.reset()
        rp.reset()
        issue = []
        for _ in range(n):
            ctx.finish()
            pre.dispatch(iters)
            t = time.perf_counter()
            with prof.section("frame"):
                r.render(cam, lights)
            issue.append((time.perf_counter() - t) * 1e3)
            ctx.finish()
        gpu = prof.samples("frame", wait=True)
        rp.flush()
        passes = {name: stats(rp.samples(name)) for name in rp.names() if rp.samples(name)}
        out = {"gpu_ms": stats(gpu), "gpu_passes_ms": passes, "gpu_preload_ms": busy_ms,
               "gpu_issue_ms": stats(issue)}
        if max(issue) > busy_ms:
            out["gpu_ms_note"] = (f"issuing a frame took up to {max(issue):.2f} ms, longer than the {busy_ms:.1f} ms "
                                  "preload: some idle gaps may remain")
        return out

    def release(self) -> None:
        if self._preload is not None:
            self._preload.release()
            self._preload = None
        try:
            self.prof.release()
        except Exception:
            pass

    # ------------------------------------------------------------------ sections
    def target(self) -> None:
        from ..render.passes.hair_compute import auto_rasterizer

        # the default model (Chiang + dual scattering) is what the target frame is judged with
        c = self.cfg["target"]
        guides = int(c["guides"])
        auto = auto_rasterizer(self.ctx)
        settings = dict(size=tuple(c["size"]), segments=TARGET_SEGMENTS, strands_per_guide=TARGET_SPG,
                        shading=TARGET_SHADING, shadows="deep_opacity", shadow_map_size=512,
                        dom_layers=(0.05, 0.15, 1.0), msaa=4, supersample=1, geometry="ribbons")
        name = f"{guides * TARGET_SPG} strands x {TARGET_SEGMENTS} seg {c['size'][0]}x{c['size'][1]}"
        self.measure("target", name, guides=guides, points=TARGET_POINTS, settings=settings,
                     required=("shading", "shadows", "shadow_map_size", "msaa", "strands_per_guide", "segments"),
                     budget_scale=5.0, shading=TARGET_SHADING, shadows="deep_opacity", shadow_map_size=512,
                     msaa=4, dom_layers=3, rasterizer=auto, raster_stats=True, still_hair=True)
        # the same frame with the other rasteriser ("auto" picked one for this GPU)
        other = "hardware" if auto == "compute" else "compute"
        self.measure("target_rasterizer", f"{name} {other} rasteriser", guides=guides, points=TARGET_POINTS,
                     settings={**settings, "rasterizer": other}, required=("rasterizer",), budget_scale=5.0,
                     shading=TARGET_SHADING, shadows="deep_opacity", shadow_map_size=512, msaa=4, dom_layers=3,
                     rasterizer=other, raster_stats=True)
        if auto == "compute":   # the head with four samples like the hair (one is the default)
            self.measure("target_rasterizer", f"{name} compute rasteriser, head multisampled", guides=guides,
                         points=TARGET_POINTS, settings={**settings, "head_msaa": True}, required=("head_msaa",),
                         budget_scale=5.0, shading=TARGET_SHADING, shadows="deep_opacity", shadow_map_size=512,
                         msaa=4, dom_layers=3, rasterizer="compute")
        self.still(guides, name, settings)

    def still(self, guides: int, name: str, settings: dict) -> None:
        """The target frame as a still picture (RenderSettings.accumulate, its default): the GPU and
        issue ms of the frames that are moved and folded into the mean (1..accumulate) against
        the frames after it, and the accumulate pass's own ms; the second still of two (the
        first compiles; the quick mode's one), each begun by a frame from another camera."""
        from ..render import Renderer
        from ..render.settings import RenderSettings

        n = int(RenderSettings().accumulate)
        with self._guard("still", f"{name}, {n} frames averaged", guides=guides, accumulate=n):
            self._before_config()
            s, _ = make_settings({**settings, "accumulate": n})
            r = Renderer(s, ctx=self.ctx, profile=1, profiler_source=self.profiler_source)
            try:
                r.set_strands(self.work.groom(guides, TARGET_POINTS))
                r.set_head(self.work.head)
                cam = r.default_camera(points=None)
                other = cam.orbited(5.0)
                rp, prof = r.profiler, self.prof
                phases = {}
                for _ in range(1 if self.mode == "quick" else 2):
                    r.render(other)
                    r.render(cam, refine=True)   # the still picture's first frame, drawn as a moving one's
                    for phase, frames in (("averaged", n), ("after", n)):
                        prof.reset()
                        rp.reset()
                        wall, submit = time_each(self.ctx, lambda: r.render(cam, refine=True), frames, prof, "frame")
                        rp.flush()
                        phases[phase] = {"frame_ms": stats(prof.samples("frame", wait=True)), "wall_ms": stats(wall),
                                         "submit_ms": stats(submit), "accumulate_ms": stats(rp.samples("accumulate") or [0.0])}
                self._row("still", f"{name}, {n} frames averaged", guides=guides, accumulate=n,
                          still_frames=r.still_frames, frame_source=prof.source, **phases, settings=settings_dict(s))
            finally:
                r.release()

    def _hunz_base(self, strands: int) -> tuple[int, dict]:
        spg = 16
        guides = max(1, int(round(strands / spg)))
        return guides, dict(size=tuple(self.cfg["hunz_size"]), segments=24, strands_per_guide=spg,
                            geometry="lines", msaa=1, supersample=1)

    def hunz_shading(self) -> None:
        from ..render.lights import default_lights

        key = [default_lights()[0]]   # one light
        for strands in self.cfg["hunz_strands"]:
            guides, base = self._hunz_base(strands)
            for model in shading_models():
                self.measure("hunz_shading", f"{guides * 16} strands {model}", guides=guides, points=13,
                             settings={**base, "shading": model, "shadows": "none"},
                             required=("shading", "shadows"), lights=key, shading=model)

    def hunz_shadows(self) -> None:
        guides, base = self._hunz_base(self.cfg["hunz_shadow_strands"])
        base = {**base, "shading": "marschner_lut"}
        methods = shadow_methods()
        self.shadow_methods = methods
        for method in methods:
            if method == "none":
                self.measure("hunz_shadows", f"{guides * 16} none", guides=guides, points=13,
                             settings={**base, "shadows": "none"}, required=("shadows",),
                             shadows="none", shadow_map_size=None, pcf=None)
                continue
            for size in self.cfg["shadow_sizes"]:
                for pcf in self.cfg["shadow_pcf"]:
                    self.measure("hunz_shadows", f"{guides * 16} {method} {size}^2 pcf {pcf}x{pcf}",
                                 guides=guides, points=13,
                                 settings={**base, "shadows": method, "shadow_map_size": size, "pcf": pcf},
                                 required=("shadows", "shadow_map_size", "pcf"),
                                 shadows=method, shadow_map_size=size, pcf=pcf)

    def _vulkan_base(self) -> dict:
        return dict(size=tuple(self.cfg["vulkan_size"]), segments=42, strands_per_guide=self.cfg["vulkan_base_spg"],
                    shading="marschner", shadows="deep_opacity", shadow_map_size=1024, pcf=4, msaa=1,
                    supersample=1, geometry="ribbons")

    def vulkan(self) -> None:
        base, cfg = self._vulkan_base(), self.cfg
        G0, spg0 = cfg["vulkan_base_guides"], cfg["vulkan_base_spg"]
        for g in cfg["vulkan_guides"]:
            self.measure("vulkan_guides", f"{g} guides x {spg0}", guides=g, points=10, settings=base,
                         required=("strands_per_guide",), parameter=g)
        for d in cfg["vulkan_divisions"]:
            self.measure("vulkan_divisions", f"{d} divisions ({G0} x {spg0})", guides=G0, points=10,
                         settings={**base, "segments": d}, required=("segments",), parameter=d)
        for spg in cfg["vulkan_spg"]:
            self.measure("vulkan_strands_per_guide", f"{spg} per guide ({G0} guides)", guides=G0, points=10,
                         settings={**base, "strands_per_guide": spg}, required=("strands_per_guide",), parameter=spg)
        for taps in cfg["vulkan_pcf_taps"]:
            side = int(round(math.sqrt(taps)))
            self.measure("vulkan_pcf", f"{side * side} taps ({G0} x {spg0})", guides=G0, points=10,
                         settings={**base, "pcf": side}, required=("pcf",), parameter=side * side, pcf=side)

    def chen_lod(self) -> None:
        on, off, how = self.lod
        G = int(self.cfg["chen_guides"])
        base = dict(segments=20, strands_per_guide=16, shading="scheuermann", shadows="deep_opacity",
                    shadow_map_size=512, msaa=1, supersample=2, geometry="ribbons")
        for size in self.cfg["chen_sizes"]:
            for dist in self.cfg["chen_distances"]:
                for lod_name, changes in (("on", on), ("off", off)):
                    name = f"{size[0]}x{size[1]} distance {dist} LOD {lod_name}"
                    fields = dict(distance=dist, lod=lod_name, lod_how=how, resolution=f"{size[0]}x{size[1]}")
                    if changes is None and lod_name == "on":
                        self._log(f"chen_lod: {name}")
                        self._skip_row("chen_lod", name, f"no LOD: {how}", guides=G, guide_points=6,
                                       strands_per_guide=16, segments_requested=20, **fields)
                        continue
                    self.measure("chen_lod", name, guides=G, points=6,
                                 settings={**base, "size": tuple(size), **(changes or {})},
                                 camera=(lambda d: lambda r: r.default_camera(distance_scale=d, points=None))(dist), **fields)

    def woodhouse(self) -> None:
        methods = [m for m in ("deep_opacity", "density") if m in shadow_methods()]
        spg = int(self.cfg["woodhouse_spg"])
        for method in methods + [m for m in ("density",) if m not in methods]:
            for msaa in (4, 1):
                name = f"242 x {spg} {method} msaa {msaa}"
                fields = dict(shadows=method, msaa=msaa,
                              version={"deep_opacity": "gpu", "density": "optimised_gpu"}[method])
                if method not in methods:
                    self._log(f"woodhouse_msaa: {name}")
                    self._skip_row("woodhouse_msaa", name, f"the renderer has no {method!r} shadows "
                                   f"(methods: {', '.join(shadow_methods())})", guides=242, guide_points=16,
                                   strands_per_guide=spg, segments_requested=15, **fields)
                    continue
                self.measure("woodhouse_msaa", name, guides=242, points=16,
                             settings=dict(size=tuple(self.cfg["woodhouse_size"]), segments=15,
                                           strands_per_guide=spg, shading="sadeghi", shadows=method,
                                           msaa=msaa, supersample=1, geometry="ribbons",
                                           # the shadow methods' comparison: Karis's cheap term, as
                                           # before "auto" became dual scattering
                                           shading_options={"multiple_scattering": "karis"}),
                             required=("msaa", "shadows"), **fields)

    def sim_render_loop(self) -> None:
        """The target's groom simulated and drawn, a step then a frame, the renderer reading the
        simulator's positions in place: the CPU's time to issue a step (``sim_submit_ms``), a
        frame (``render_submit_ms``) and both (``cpu_submit_ms``), each after a ``finish`` and
        with no profiler section; and the loop back to back (``pipelined_ms``)."""
        from ..render import Renderer
        from ..sim import Simulator

        ctx, cfg = self.ctx, self.cfg
        c = self.cfg["target"]
        guides = int(c["guides"])
        self._log(f"sim_render_loop: {guides} guides")
        sim = r = None
        try:
            self._before_config()
            s, _ = make_settings(dict(size=tuple(c["size"]), segments=TARGET_SEGMENTS, strands_per_guide=TARGET_SPG,
                                      shading=TARGET_SHADING, shadows="deep_opacity", shadow_map_size=512,
                                      dom_layers=(0.05, 0.15, 1.0), msaa=4, supersample=1, geometry="ribbons"), ())
            sim = Simulator(self.work.groom(guides, TARGET_POINTS), ctx=ctx)
            r = Renderer(s, ctx=ctx, profile=False)
            r.set_strands(sim)
            r.set_head(self.work.head)
            cam = r.default_camera(points=None)

            def step():
                sim.step()
                r.strands_changed()

            def loop():
                step()
                r.render(cam, None)

            loop()                 # compiles the kernels and programs
            ctx.finish()
            t = time.perf_counter()
            loop()
            ctx.finish()
            per = time.perf_counter() - t
            budget = float(cfg["config_budget_s"]) * 5.0
            if per * 6 > budget:
                self.loop = {"status": "skipped", "reason": f"too slow for the {self.mode} mode's budget: a step "
                                                            f"and a frame take {per * 1e3:.0f} ms"}
                return
            n = max(3, min(int(cfg["frames"]), 30, int(budget / (per * 2.5))))
            sims, frames, both = [], [], []
            for _ in range(n):
                ctx.finish()
                t0 = time.perf_counter()
                step()
                t1 = time.perf_counter()
                r.render(cam, None)
                t2 = time.perf_counter()
                sims.append((t1 - t0) * 1e3)
                frames.append((t2 - t1) * 1e3)
                both.append((t2 - t0) * 1e3)
            self.loop = {"guides": guides, "rendered_strands": r.rendered_strands, "size": list(s.size),
                         "iterations": n, "sim_submit_ms": stats(sims), "render_submit_ms": stats(frames),
                         "cpu_submit_ms": stats(both), "pipelined_ms": time_pipelined(ctx, loop, n)}
        except Exception as exc:   # the loop is one more figure; the benchmark goes on
            self.loop = {"status": "error", "reason": f"{type(exc).__name__}: {exc}"}
        finally:
            for o in (r, sim):
                if o is not None:
                    o.release()

    def run_all(self) -> None:
        self.target()          # first: it is the one number the issue asks for
        self.sim_render_loop()
        self.hunz_shading()
        self.hunz_shadows()
        self.vulkan()
        self.chen_lod()
        self.woodhouse()


# --------------------------------------------------------------------------- analysis
def _targets(rows: list[dict], mode: str) -> dict:
    out = {"full_head_50k_ms": None, "target_ms": TARGET_MS, "met": False,
           "metric": "mean GPU time of a whole frame: GL_TIMESTAMP pair around Renderer.render with the GPU kept "
                     "busy while the frame is issued (gpu_ms, no idle gaps); where GPU timer queries are not "
                     "used (software renderers) the CPU wall with ctx.finish() (frame_ms)",
           "configuration": f"{TARGET_GUIDES} guides x {TARGET_SPG} = 50,000 strands x {TARGET_SEGMENTS} segments, "
                            f"{TARGET_SIZE[0]}x{TARGET_SIZE[1]}, {TARGET_SHADING} + dual scattering, deep opacity maps 3 layers "
                            "512^2, 4x MSAA, 3 lights, head"}
    row = next((r for r in rows if r["bench"] == "target"), None)
    if row is None:
        out["note"] = "the target configuration was not run"
        return out
    if row["status"] != "ok":
        out["note"] = f"the target configuration was {row['status']}: {row['reason']}"
        return out
    full = row.get("rendered_strands") == TARGET_GUIDES * TARGET_SPG and tuple(row["size"]) == TARGET_SIZE
    gapless = (row.get("gpu_ms") or {}).get("mean") is not None
    main = row["gpu_ms"] if gapless else row["frame_ms"]
    v = main["mean"]
    passes = {k: st["mean"] for k, st in ((row.get("gpu_passes_ms") if gapless else row["passes_ms"]) or {}).items()}
    summary = dict(median_ms=main["median"], p95_ms=main["p95"], measured_as="gpu_ms" if gapless else "frame_ms",
                   frame_ms=row["frame_ms"]["mean"], passes_ms=passes,
                   passes_sum_ms=(row.get("passes_sum_ms") or {}).get("mean"),
                   wall_ms=row["wall_ms"]["mean"], pipelined_ms=row["pipelined_ms"],
                   cpu_submit_ms=row["submit_ms"]["mean"],
                   cpu_submit_bare_ms=(row.get("submit_bare_ms") or {}).get("mean"), source=row["frame_source"],
                   rendered_strands=row["rendered_strands"], rendered_segments=row["rendered_segments"])
    still = row.get("still_hair")
    if still:   # the same frame with its light-space targets reused (Bench._still_hair)
        summary["still_hair"] = dict(gpu_ms=(still.get("gpu_ms") or {}).get("mean"), pipelined_ms=still["pipelined_ms"],
                                     cpu_submit_bare_ms=still["submit_bare_ms"]["mean"],
                                     cpu_submit_bare_median_ms=still["submit_bare_ms"]["median"], kept=still["kept"])
    orbit = row.get("orbit")
    if orbit:   # the same frame, the camera turning (Bench._orbit)
        summary["orbit"] = dict(cpu_submit_bare_ms=orbit["submit_bare_ms"]["mean"],
                                cpu_submit_bare_median_ms=orbit["submit_bare_ms"]["median"],
                                pipelined_ms=orbit["pipelined_ms"])
    drawn = row.get("drawn")
    if drawn:   # the same frame, every frame drawn (no recording played: Bench._drawn)
        summary["drawn"] = dict(cpu_submit_bare_ms=drawn["submit_bare_ms"]["mean"],
                                cpu_submit_bare_median_ms=drawn["submit_bare_ms"]["median"])
    summary["cpu_submit_bare_median_ms"] = (row.get("submit_bare_ms") or {}).get("median")
    if not full:
        out["note"] = (f"not measured in {mode} mode (run without --quick); stand-in {row['name']}: "
                       f"{fmt(v)} ms")
        out["stand_in"] = dict(summary, name=row["name"], value_ms=v)
        return out
    out.update(full_head_50k_ms=v, met=bool(v is not None and v <= TARGET_MS), **summary)
    ps, sub = summary["passes_sum_ms"], summary["cpu_submit_ms"]
    out["met_by_passes"] = bool(ps is not None and ps <= TARGET_MS)
    if v is not None and sub is not None:
        out["likely_bound"] = ("cpu: issuing a frame (Python + driver) takes longer than the GPU runs it"
                               if sub > v else "gpu")
    return out


def _sweep_summary(rows: list[dict], bench) -> dict:
    out = {}
    for name in SECTIONS:
        rs = [r for r in rows if r["bench"] == name]
        out[name] = {"reference": REFERENCES.get(name), "configurations": len(rs),
                     "ok": sum(r["status"] == "ok" for r in rs),
                     "skipped": sum(r["status"] == "skipped" for r in rs),
                     "error": sum(r["status"] == "error" for r in rs)}
    out["hunz_shadows"]["methods"] = list(getattr(bench, "shadow_methods", shadow_methods()))
    out["hunz_shading"]["models"] = shading_models()
    on, off, how = bench.lod
    out["chen_lod"]["lod"] = {"available": on is not None, "how": how}
    # Woodhouse: what 4x MSAA costs, per shadow method
    aa = {}
    for r in rows:
        if r["bench"] == "woodhouse_msaa" and r["status"] == "ok":
            aa.setdefault(r["shadows"], {})[r["msaa"]] = r["frame_ms"]["mean"]
    out["woodhouse_msaa"]["msaa_cost_ms"] = {m: (v[4] - v[1]) if 4 in v and 1 in v else None for m, v in aa.items()}
    return out


# sections run only when asked for (``mane bench render --section scale``), not by default
EXTRA_SECTIONS = ("scale",)
RUN_SECTIONS = {"target": "target", "target_rasterizer": "target", "hunz_shading": "hunz_shading",
                "hunz_shadows": "hunz_shadows", "vulkan_guides": "vulkan", "vulkan_divisions": "vulkan",
                "vulkan_strands_per_guide": "vulkan", "vulkan_pcf": "vulkan", "chen_lod": "chen_lod",
                "woodhouse_msaa": "woodhouse"}


def run_sections(bench, sections) -> None:
    """The named sections (``SECTIONS``, ``EXTRA_SECTIONS``) in order, each method once."""
    check_sections("render bench", sections, {*RUN_SECTIONS, *EXTRA_SECTIONS}, SECTIONS + EXTRA_SECTIONS)
    done = set()
    for s in sections:
        method = RUN_SECTIONS.get(s, s)
        if method in done:
            continue
        done.add(method)
        if method == "scale":
            from .scale_bench import RenderScale

            RenderScale(bench).run()
        else:
            getattr(bench, method)()


def run(ctx, mode: str = "default", progress=None, sections=None) -> dict:
    """Every section of ``mode`` ("quick", "default", "full"), or only ``sections`` (names of
    ``SECTIONS`` and ``EXTRA_SECTIONS``: "scale" is issue 14's rows, mane.bench.scale_bench):
    the JSON object."""
    bench = Bench(ctx, mode, progress)
    try:
        if sections:
            run_sections(bench, list(sections))
        else:
            bench.run_all()
    finally:
        bench.release()
    cfg = bench.cfg
    timing = {
        "frame_source": bench.prof.source,
        "frame_source_reason": bench.prof.reason,
        "pass_source": bench.pass_source,
        "pass_source_reason": bench.pass_source_reason,
        "pass_names": list(bench.pass_names),
        "note": ("frame_ms: a profiler section around Renderer.render (GPU timestamps include idle gaps while "
                 "Python issues passes); passes_sum_ms: the renderer's per-pass sections summed per frame; "
                 "pipelined_ms: N frames back to back, per-pass timing off, wall / N."),
        "gpu_preload": {"iterations_per_ms": bench._preload_rate, "note": bench.preload_note,
                        "what": "gpu_ms: the frame's timestamps with the GPU kept busy by a serial compute "
                                "job while the frame is issued, so the GPU runs it without idle gaps"},
        "total_seconds": time.perf_counter() - bench.started,
    }
    settings = {k: ([list(x) if isinstance(x, tuple) else x for x in v] if isinstance(v, list)
                    else list(v) if isinstance(v, tuple) else v) for k, v in cfg.items()}
    settings["workload"] = (f"procedural default scene (mane.grooming.scene: default head, groom from "
                            f"{bench.work.source or 'default_groom'}); a configuration renders the first G guides")
    settings["render_settings_fields"] = list(settings_fields())
    settings["sections"] = list(sections) if sections else list(SECTIONS)
    if sections and "scale" in sections:
        from .scale_rows import SCALE_CONFIG

        settings["scale"] = SCALE_CONFIG[mode]
    out = {"meta": envelope(ctx, target="render", mode=mode, settings=settings, timing=timing),
           "results": bench.rows,
           "targets": {**_targets(bench.rows, mode), "sim_render_loop": bench.loop},
           "sweeps": _sweep_summary(bench.rows, bench)}
    if sections and "scale" in sections:
        from .scale_rows import summary

        out["scale"] = summary(bench.rows)
    return out


# --------------------------------------------------------------------------- text output
def _pass(name):
    return lambda r: ((r.get("passes_ms") or {}).get(name) or {}).get("mean")


def format_text(result: dict) -> str:
    meta, rows = result["meta"], result["results"]
    tm = meta["timing"]
    out = [title_line(meta),
           f"timing: frame {tm['frame_source']}, passes {tm['pass_source']}; all times ms (GPU unless said); "
           f"{tm['total_seconds']:.1f} s in all"]
    names = tm.get("pass_names") or []
    ok = lambda bench: [r for r in rows if r["bench"] == bench and r["status"] == "ok"]  # noqa: E731
    frame_cols = [("gpu", stat_of("gpu_ms", "mean"), "{:.3f}"),
                  ("frame", stat_of("frame_ms", "mean"), "{:.3f}"), ("median", stat_of("frame_ms", "median"), "{:.3f}"),
                  ("p95", stat_of("frame_ms", "p95"), "{:.3f}"), ("passes", stat_of("passes_sum_ms", "mean"), "{:.3f}"),
                  ("wall", stat_of("wall_ms", "mean"), "{:.3f}"), ("pipelined", "pipelined_ms", "{:.3f}"),
                  ("fps", "fps", "{:.0f}")]
    size_cols = [("strands", "rendered_strands", "{:d}"), ("segments", "rendered_segments", "{:d}")]
    titles = {
        "target": "Target (issue 4): 50k strands x 32 segments, 1920x1080, Marschner LUT, DOM 512^2, 4x MSAA "
                  "(quick: a small stand-in)",
        "target_rasterizer": "The target's frame with the other rasteriser (hardware / compute)",
        "hunz_shading": "Hunz Fig. 33: strands x shading model (one light, no shadows, GL_LINES)",
        "hunz_shadows": "Hunz Fig. 36: shadow method x map size x PCF",
        "vulkan_guides": "Vulkan: guide strands",
        "vulkan_divisions": "Vulkan: tessellation divisions per strand",
        "vulkan_strands_per_guide": "Vulkan: strands per guide",
        "vulkan_pcf": "Vulkan: PCF taps",
        "chen_lod": "Chen Table 5: viewing distance (x framing distance), LOD on / off",
        "woodhouse_msaa": "Woodhouse Table 5.1: his workload with and without 4x MSAA",
    }
    asked = meta.get("settings", {}).get("sections") or SECTIONS
    for section in SECTIONS:
        rs = ok(section)
        if not rs and section not in asked:
            continue
        out.append("")
        seen = {n for r in rs for n in (r.get("passes_ms") or {})}
        pass_cols = [(n, _pass(n), "{:.3f}") for n in names if n in seen and n != "frames"]
        out.append(table(rs, [("config", "name", "{}")] + size_cols + frame_cols + pass_cols,
                         title=titles[section]))
    for r in ok("still"):
        a, b = r["averaged"], r["after"]
        out += ["", f"Still picture ({r['name']}): the frames averaged {a['frame_ms']['median']:.3f} ms "
                    f"(accumulate pass {a['accumulate_ms']['median']:.3f}, issue {a['submit_ms']['median']:.3f}), "
                    f"the frames after {b['frame_ms']['median']:.3f} ms (issue {b['submit_ms']['median']:.3f})"]
    if result.get("scale") is not None:
        from .scale_rows import format_text as scale_text

        out += ["", scale_text(rows)]
    t = result["targets"]
    val = t.get("full_head_50k_ms")
    out.append("")
    out.append(f"target: 50k x 32 frame <= {t['target_ms']} ms: "
               + (f"{val:.3f} ms -> {'MET' if t['met'] else 'NOT met'} (passes {fmt(t.get('passes_sum_ms'))} ms, "
                  f"CPU issue {fmt(t.get('cpu_submit_ms'))} ms ({fmt(t.get('cpu_submit_bare_ms'))} ms without the "
                  f"profiler), pipelined {fmt(t.get('pipelined_ms'))} ms; "
                  f"bound: {t.get('likely_bound', '?')})" if val is not None else f"not measured ({t.get('note', '')})"))
    ob = t.get("orbit") or (t.get("stand_in") or {}).get("orbit")
    if ob:
        which = "the target frame" if t.get("orbit") else "its stand-in"
        out.append(f"{which}, camera turning {ORBIT_DEGREES} degrees a frame: CPU issue median "
                   f"{fmt(ob['cpu_submit_bare_median_ms'])} ms (mean {fmt(ob['cpu_submit_bare_ms'])}), "
                   f"pipelined {fmt(ob['pipelined_ms'])} ms")
    dr = t.get("drawn")
    if dr:
        out.append(f"the target frame's CPU issue median {fmt(t.get('cpu_submit_bare_median_ms'))} ms (frames played from "
                   f"their recording once confirmed), {fmt(dr['cpu_submit_bare_median_ms'])} ms with every frame drawn")
    lp = t.get("sim_render_loop") or {}
    if lp.get("cpu_submit_ms"):
        out.append(f"simulate + render ({lp['guides']} guides): CPU issue {fmt(lp['cpu_submit_ms']['mean'])} ms "
                   f"(step {fmt(lp['sim_submit_ms']['mean'])}, frame {fmt(lp['render_submit_ms']['mean'])}), "
                   f"pipelined {fmt(lp['pipelined_ms'])} ms")
    elif lp.get("reason"):
        out.append(f"simulate + render: {lp['reason']}")
    aa = result.get("sweeps", {}).get("woodhouse_msaa", {}).get("msaa_cost_ms") or {}
    if aa:
        out.append("4x MSAA costs (Woodhouse workload): " + ", ".join(f"{m} {fmt(v)} ms" for m, v in aa.items()))
    bad = failures_table(rows)
    if bad:
        out += ["", bad]
    return "\n".join(out)


__all__ = ["run", "format_text", "MODE_CONFIG", "Bench", "Workloads", "make_settings", "settings_fields",
           "shadow_methods", "shading_models", "lod_switch", "TARGET_MS"]
