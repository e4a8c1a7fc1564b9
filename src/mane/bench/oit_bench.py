"""``mane bench oit``: GPU milliseconds and bytes of the hair transparency methods.

    result = run(ctx, "default")          # the JSON object; format_text(result) for tables

Sections:

``methods``
    every OIT method (and "none", the depth-tested blending; the K-buffer in each insertion
    form the GPU has) x shadow method {none, shadow_map, adsm, deep_opacity} (Hunz Fig. 41,
    3x3 PCF) x viewport {656x861 (Hunz's), 1920x1080} x groom {straight, wavy, curly}: GPU
    ms of the frame, of the OIT pass (``passes_ms.oit``) and of the others; ``oit_bytes``
    (what the method holds at that size), fragments per pixel, overflow, the DBK shift.
    Each row's ``rasterizer`` says who drew the hair: "hardware" (triangles) or "compute"
    (the compute rasteriser: the A-buffer, K-buffer, DBK-buffer, ShortCut and "none" have a
    compute form, mane.render.oit.compute); the mode's ``rasterizers`` are run for each
    method that has that form (``oit_keys``: the compute form's 64- or 32-bit keys).
``memory``
    bytes per method at 656x861 and 1920x1080 beside Hunz's Fig. 42 (his MB are MiB).
``target``
    the issue's goal: the DBK-buffer with deep opacity maps at 1920x1080, 50,000 strands,
    at most 6 ms of GPU time a frame (one row per rasterizer).

Workloads (procedural, no files): the default head and groom (``mane.grooming.scene``) with
50,000 rendered strands (guides x 16), 24 segments a strand, seen from the side (Hunz's
view); "wavy" and "curly" add the renderer's curl (radius 4 mm x 3 turns, 7 mm x 8 turns).
Strand opacity 0.5 (Hunz's k = 6 example: 0.5^6 ~ 1.6 %).

Timing of a configuration: warm-up frames (compilation, pool growth, the DBK shift's
calibration), then N frames each in a ``GpuProfiler`` section (GL_TIMESTAMP on a real GPU;
CPU wall with ``finish`` on software renderers) and the renderer's per-pass sections. A
configuration that does not fit, lacks a GL feature or is too slow for the mode's budget is
recorded with ``status: "skipped"`` and the reason.
"""
from __future__ import annotations

import time
import traceback

import numpy as np

from ..errors import GLFeatureError, GPUMemoryError, UsageError
from .common import title_line, BenchRows, Skip, envelope, fmt, stats, table, time_each

HUNZ_SIZE = (656, 861)
HD_SIZE = (1920, 1080)
TARGET_MS = 6.0
TARGET_STRANDS = 50_000
SPG = 16
GROOMS = {"straight": dict(curl_radius=0.0), "wavy": dict(curl_radius=0.004, curl_frequency=3.0),
          "curly": dict(curl_radius=0.007, curl_frequency=8.0)}
SHADOWS = ("none", "shadow_map", "adsm", "deep_opacity")
METHODS = ("none", "sorted_blending", "random_subsets", "a_buffer", "k_buffer", "dbk_buffer", "shortcut")
RASTERIZERS = ("hardware", "compute")

MODE_CONFIG = {
    "quick": dict(strands=512, sizes=[(164, 215)], grooms=("straight",), shadows=("none", "deep_opacity"),
                  warmup=3, frames=2, config_budget_s=6.0, total_budget_s=240.0, shadow_map_size=128,
                  memory_sizes=[(164, 215)], rasterizers=RASTERIZERS),
    "default": dict(strands=TARGET_STRANDS, sizes=[HUNZ_SIZE, HD_SIZE], grooms=tuple(GROOMS), shadows=SHADOWS,
                    warmup=6, frames=20, config_budget_s=8.0, total_budget_s=300.0, shadow_map_size=512,
                    memory_sizes=[HUNZ_SIZE, HD_SIZE], rasterizers=RASTERIZERS, gpu_warmup_s=3.0),
    "full": dict(strands=TARGET_STRANDS, sizes=[HUNZ_SIZE, HD_SIZE], grooms=tuple(GROOMS), shadows=SHADOWS,
                 warmup=8, frames=60, config_budget_s=20.0, total_budget_s=4000.0, shadow_map_size=512,
                 memory_sizes=[HUNZ_SIZE, HD_SIZE], rasterizers=RASTERIZERS, gpu_warmup_s=3.0),
}

REFERENCES = {
    "hunz_fig41": "Hunz 2016 Fig. 41 (GTX 960, 656x861, Straight 50k strands, 3x3 PCF): DBK-buffer with DOM "
                  ">= 50 FPS (20 ms), with ADSM ~58 FPS (17.2 ms); random subsets (k = 8) with DOM 91 FPS "
                  "(11 ms), with ADSM 125 FPS (8 ms); A-buffer slowest, K+-buffer 'faster, but still slow'.",
    "hunz_fig42": "Hunz 2016 Fig. 42 at 656x861 (MiB): random subsets 34.47, K+-buffer 36.63, A-buffer 150.46 "
                  "(12,959,208 fragments), DBK-buffer 59.25 (PPLL 53.86, 4,518,344 fragments), TressFX A-buffer "
                  "~276 (930 at 1920x1080).",
    "target": "Issue 5: DBK-buffer with deep opacity maps at 1920x1080, 50,000 strands: <= 6 ms GPU a frame.",
}


def _method_variants(ctx, rasterizers=("hardware",)) -> list[tuple[str, dict]]:
    """(label, settings) of the methods for each rasterizer that has them (the settings hold
    ``rasterizer``); the K-buffer once per insertion form available (hardware: atomic32,
    interlock, atomic64; compute: atomic32 and atomic64 keys)."""
    from ..gpu.capabilities import get_capabilities
    from ..render.oit.compute import COMPUTE_METHODS

    caps = get_capabilities(ctx)
    out = []
    for ras in rasterizers:
        for m in METHODS:
            if ras == "compute" and m not in COMPUTE_METHODS and m != "none":
                continue
            base = {"oit": m, "rasterizer": ras}
            if m != "k_buffer":
                out.append((m, base))
                continue
            forms = ["atomic32"]
            if ras == "hardware" and caps.has_extension("GL_ARB_fragment_shader_interlock"):
                forms.append("interlock")
            if caps.available("kbuffer_int64"):
                forms.append("atomic64")
            for f in forms:
                out.append((f"k_buffer/{f}", {**base, "oit_kbuffer": f}))
    return out


class Bench(BenchRows):
    def __init__(self, ctx, mode: str = "default", progress=None):
        self._start(ctx, mode, MODE_CONFIG, progress, history=100_000)
        self.cfg = MODE_CONFIG[mode]
        self._groom = None
        self._head = None

    def scene(self):
        if self._groom is None:
            from ..grooming.scene import default_groom, default_head

            self._head = default_head(4)  # the 5,120-triangle bust the benchmarks were measured on
            guides = max(1, int(round(self.cfg["strands"] / SPG)))
            g = default_groom(self._head, guides, 13)
            if g.uniform_count != 13:
                g = g.resampled(13)
            self._groom = g if g.num_strands <= guides else g.subset(np.arange(guides))
            self._log(f"groom: {self._groom.num_strands} guides x {SPG} = {self._groom.num_strands * SPG} strands")
        return self._groom, self._head

    def settings(self, size, shadows, groom_kind, extra):
        from ..render import RenderSettings

        base = dict(size=tuple(size), segments=24, strands_per_guide=SPG, shadows=shadows, pcf=3,
                    shadow_map_size=int(self.cfg["shadow_map_size"]), msaa=1, supersample=1, oit_opacity=0.5,
                    **GROOMS[groom_kind], **extra)
        try:
            return RenderSettings(**{**base, "shading": "marschner_lut"})
        except UsageError:
            return RenderSettings(**base)

    def measure(self, label: str, size, shadows: str, groom_kind: str, extra: dict, section: str = "methods"):
        row = {"bench": section, "method": label, "size": list(size), "shadows": shadows, "groom": groom_kind,
               "rasterizer": extra.get("rasterizer", "auto"), "status": "ok", "reason": None}
        self._log(f"{section}: {label} [{row['rasterizer']}] {size[0]}x{size[1]} {shadows} {groom_kind}")
        try:
            elapsed = time.perf_counter() - self.started
            if elapsed > self.cfg["total_budget_s"]:
                raise Skip(f"the {self.mode} mode's time budget ({self.cfg['total_budget_s']:.0f} s) is spent")
            row.update(self._time(self.settings(size, shadows, groom_kind, extra)))
        except (Skip, UsageError, GLFeatureError, GPUMemoryError) as exc:
            row.update(status="skipped", reason=f"{type(exc).__name__}: {exc}")
        except Exception as exc:   # the benchmark goes on; the row says what broke
            row.update(status="error", reason=f"{type(exc).__name__}: {exc}"[:400],
                       traceback=traceback.format_exc(limit=5))
            self._log(f"  error: {type(exc).__name__}: {exc}")
        self.rows.append(row)
        return row

    def _time(self, s) -> dict:
        from ..render import Renderer

        ctx, cfg = self.ctx, self.cfg
        groom, head = self.scene()
        r = Renderer(s, ctx=ctx, profile=1)   # every frame
        try:
            r.set_strands(groom)
            r.set_head(head)
            cam = r.default_camera(azimuth=90.0, elevation=5.0, points=None)
            walls = [ms / 1e3 for ms in time_each(ctx, lambda: r.render(cam), max(2, int(cfg["warmup"])))[0]]
            per = min(walls[1:])
            if per * 4 > cfg["config_budget_s"]:
                raise Skip(f"too slow for the {self.mode} mode: {per * 1e3:.0f} ms a frame")
            n = max(2, min(int(cfg["frames"]), int(cfg["config_budget_s"] / max(per, 1e-4) / 2)))
            self.prof.reset()
            r.profiler.reset()
            for _ in range(n):
                with self.prof.section("frame"):
                    r.render(cam)
            frame = stats(self.prof.samples("frame", wait=True))
            r.profiler.flush()
            passes = {k: stats(r.profiler.samples(k)) for k in r.profiler.names() if r.profiler.samples(k)}
            st = r.stats()
            oit = {k: v for k, v in st.items() if k.startswith("oit") and k != "oit_bytes_detail"}
            return {"rasterizer": st.get("rasterizer"), "frame_ms": frame, "oit_ms": passes.get("oit", {}).get("mean"),
                    "passes_ms": {k: v["mean"] for k, v in passes.items()}, "frames_timed": n,
                    "timing": self.prof.source, "first_frame_s": walls[0], "rendered_strands": st["rendered_strands"],
                    "oit_bytes": st.get("oit_bytes", 0), "oit_bytes_detail": st.get("oit_bytes_detail"), **oit}
        finally:
            r.release()

    # ------------------------------------------------------------------ sections
    def variants(self):
        return _method_variants(self.ctx, self.cfg.get("rasterizers", ("hardware",)))

    def methods(self) -> None:
        # the rasteriser "auto" picks on this GPU first, so that a time budget spent on the other
        # (on a GPU with few raster units, far slower) leaves its sweep whole
        from ..render.passes.hair_compute import auto_rasterizer

        variants = self.variants()
        auto = auto_rasterizer(self.ctx)
        for ras in sorted({e["rasterizer"] for _, e in variants}, key=lambda x: x != auto):
            for size in self.cfg["sizes"]:
                for groom_kind in self.cfg["grooms"]:
                    for shadows in self.cfg["shadows"]:
                        for label, extra in variants:
                            if extra["rasterizer"] == ras:
                                self.measure(label, size, shadows, groom_kind, extra)

    def target(self) -> dict:
        """The DBK-buffer with deep opacity maps (compute rasteriser first: the issue's GPU is
        an H200, whose raster units are few)."""
        size = HD_SIZE if self.mode != "quick" else self.cfg["sizes"][0]
        out = []
        for ras in sorted(self.cfg.get("rasterizers", ("hardware",)), key=lambda x: x != "compute"):
            rows = [r for r in self.rows if r["method"] == "dbk_buffer" and r["shadows"] == "deep_opacity"
                    and tuple(r["size"]) == tuple(size) and r["status"] == "ok" and r.get("rasterizer") == ras]
            if not rows:
                rows = [self.measure("dbk_buffer", size, "deep_opacity", "straight",
                                     {"oit": "dbk_buffer", "rasterizer": ras}, "target")]
            for r in rows:
                ms = (r.get("frame_ms") or {}).get("mean")
                out.append({"groom": r["groom"], "size": r["size"], "rasterizer": r.get("rasterizer"),
                            "oit_keys": r.get("oit_keys"), "frame_ms": ms, "oit_ms": r.get("oit_ms"),
                            "passes_ms": r.get("passes_ms"), "target_ms": TARGET_MS,
                            "met": None if ms is None else ms <= TARGET_MS, "strands": r.get("rendered_strands"),
                            "timing": r.get("timing"), "status": r["status"], "reason": r.get("reason")})
        return {"goal": REFERENCES["target"], "rows": out}

    def memory(self) -> list[dict]:
        """Bytes per method and size: measured (the straight groom, shadows none) and the thesis'."""
        from ..render.oit.base import HUNZ_MEMORY_MIB, MiB

        out = []
        for size in self.cfg["memory_sizes"]:
            for label, extra in self.variants():
                ras = extra.get("rasterizer", "hardware")
                rows = [r for r in self.rows if r["method"] == label and tuple(r["size"]) == tuple(size)
                        and r["status"] == "ok" and r.get("rasterizer", "hardware") == ras]
                if not rows:
                    continue
                r = min(rows, key=lambda x: (x["groom"] != "straight", x["shadows"] != "none"))
                base = label.split("/")[0]
                out.append({"method": label, "rasterizer": ras, "size": list(size), "groom": r["groom"],
                            "oit_bytes": r["oit_bytes"],
                            "oit_mib": r["oit_bytes"] / MiB, "bytes_needed": r.get("oit_bytes_needed"),
                            "fragments_per_pixel": r.get("oit_fragments_per_pixel"),
                            "layer_fragments_per_pixel": r.get("oit_layer_fragments_per_pixel"),
                            "hunz_mib": HUNZ_MEMORY_MIB.get(base) if tuple(size) == HUNZ_SIZE else None})
        return out

    def warm_up(self) -> None:
        """Frames of the target's scene for ``gpu_warmup_s`` seconds before anything is timed: a
        GPU's clocks take a while to ramp up (the first configuration measured cold ran every
        pass, head and shadow map included, markedly slower than later ones)."""
        seconds = float(self.cfg.get("gpu_warmup_s", 0.0))
        if seconds <= 0:
            return
        from ..render import Renderer

        groom, head = self.scene()
        size = HD_SIZE if self.mode != "quick" else self.cfg["sizes"][0]
        r = Renderer(self.settings(size, "deep_opacity", "straight", {"oit": "none"}), ctx=self.ctx, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(head)
            cam = r.default_camera(azimuth=90.0, elevation=5.0, points=None)
            end = time.perf_counter() + seconds
            while time.perf_counter() < end:
                r.render(cam)
                self.ctx.finish()
        finally:
            r.release()

    def run_all(self) -> dict:
        self.warm_up()
        target = self.target()  # first, so that a spent time budget never leaves it unmeasured
        self.methods()
        return {"methods": self.rows, "memory": self.memory(), "target": target}


def run(ctx, mode: str = "default", progress=None) -> dict:
    b = Bench(ctx, mode, progress)
    body = b.run_all()
    meta = envelope(ctx, target="oit", mode=mode,
                    settings={"strands": b.cfg["strands"], "strands_per_guide": SPG, "segments": 24,
                              "sizes": b.cfg["sizes"], "grooms": {k: GROOMS[k] for k in b.cfg["grooms"]},
                              "shadows": b.cfg["shadows"], "shadow_map_size": b.cfg["shadow_map_size"],
                              "rasterizers": list(b.cfg.get("rasterizers", ("hardware",))),
                              "pcf": 3, "oit_opacity": 0.5, "msaa": 1, "view": "side (azimuth 90)"},
                    timing={"frame": b.prof.source, "warmup": b.cfg["warmup"], "frames": b.cfg["frames"]})
    return {"meta": meta, "references": REFERENCES, **body}


def _status(r: dict) -> str:
    return r["status"] if r["status"] == "ok" else f"{r['status']}: {str(r['reason'])[:60]}"


def _rasterizer(r: dict) -> str:
    ras = r.get("rasterizer") or "-"
    keys = r.get("oit_keys")
    return f"{ras}/{keys}" if ras == "compute" and keys else ras


def _met(r: dict) -> str:
    return "-" if r.get("met") is None else "met" if r["met"] else "NOT met"


def format_text(result: dict) -> str:
    meta = result.get("meta", {})
    out = [title_line(meta)]
    rows = [r for r in result.get("methods", [])]

    def ms(r, key="frame_ms"):
        v = r.get(key)
        return v.get("mean") if isinstance(v, dict) else v

    cols = [("method", "method", "{}"), ("rasterizer", _rasterizer, "{}"),
            ("size", lambda r: f"{r['size'][0]}x{r['size'][1]}", "{}"),
            ("groom", "groom", "{}"), ("shadows", "shadows", "{}"), ("frame ms", lambda r: ms(r), "{:.2f}"),
            ("oit ms", "oit_ms", "{:.2f}"), ("MiB", lambda r: (r.get("oit_bytes") or 0) / 2**20, "{:.1f}"),
            ("frag/px", "oit_fragments_per_pixel", "{:.1f}"), ("overflow", "oit_overflow", "{}"),
            ("status", _status, "{}")]
    out.append(table(rows, cols, title="\nmethods x shadows (Hunz Fig. 41):"))
    mem = result.get("memory", [])
    out.append(table(mem, [("method", "method", "{}"), ("rasterizer", _rasterizer, "{}"),
                           ("size", lambda r: f"{r['size'][0]}x{r['size'][1]}", "{}"),
                           ("MiB", "oit_mib", "{:.2f}"), ("Hunz MiB", "hunz_mib", "{:.2f}"),
                           ("frag/px", "fragments_per_pixel", "{:.1f}"),
                           ("layer frag/px", "layer_fragments_per_pixel", "{:.1f}")],
                     title="\nmemory (Hunz Fig. 42, his viewport 656x861):"))
    t = result.get("target", {})
    out.append("\ntarget: " + str(t.get("goal")))
    for r in t.get("rows", []):
        out.append(f"  {r['groom']} {r['size'][0]}x{r['size'][1]} [{_rasterizer(r)}]: "
                   f"{fmt(r['frame_ms'], '{:.2f}')} ms a frame "
                   f"(oit {fmt(r['oit_ms'], '{:.2f}')} ms) -> {_met(r)}"
                   f" [{r.get('timing')}]")
    return "\n".join(out)
