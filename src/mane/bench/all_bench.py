"""``mane bench all --out DIR [--quick | --full] [--only sim,render,...] [--baseline DIR2]``: every
benchmark in turn, and the files for the performance and quality documents.

    result = run(ctx, "quick", out_dir="out/bench")      # the index object (DIR/all.json)

Runs each registered target of ``mane bench`` (``mane.bench.targets.TARGETS`` other than ``all``:
sim, render, oit, quality, limits, in that order, those whose module imports), with a progress bar over
the targets' sections, and writes into DIR:

``<target>.json``
    each target's JSON, exactly as ``mane bench <target> --json`` prints it (a target that fails
    gets ``{"meta", "error", "traceback"}``).
``<target>_<table>.csv``
    one CSV per sweep / table: the rows of that section with nested timings flattened
    (``frame_ms.mean``, ``passes_ms.hair.mean``, ...); ``scaling.csv`` / ``scaling_summary.csv``
    (power-law fits, ``mane.bench.scaling``); ``limits_distance.csv`` (each stage against the limits
    ``limits.json`` measured: ``mane.bench.limits.distance_rows``); ``seed_figures.csv`` (every published value with its
    source); ``baseline_comparison.csv`` with ``--baseline``.
``plots/*.png``
    one figure per seed figure (``mane.bench.plots``), the seed's published values drawn in,
    and ``scaling.png``; ``quality/*.png``: the validation images (``mane.bench.quality``).
``summary.md``
    the tables of the issue (Woodhouse 5.1/5.2, Chen 2/4/5, Hunz 33/36/41/42, the Vulkan charts)
    beside the published numbers, the targets, the scaling exponents, the distance from the
    hardware limits, the validation results, and what was skipped; each table names the GPU,
    driver and settings.
``all.json``
    the index: per target status, seconds and files; every file written; the fits.

``--only sim,render`` runs those targets; the JSON of other targets already in DIR (an earlier
``--only`` run) is loaded, so a run split over several commands still gives one summary and one
set of plots; ``--only none`` runs nothing and rebuilds the files from DIR's JSON.

``--baseline DIR2`` takes another run's output (e.g. ``--quick`` on a CPU machine, llvmpipe)
and puts its times beside this run's for every configuration both ran (same section and name):
the CPU column for the small workloads.
"""
from __future__ import annotations

import csv
import importlib
import importlib.util
import json
import math
import sys
import time
import traceback
from pathlib import Path

from .common import sanitise, to_json

ORDER = ("sim", "render", "oit", "quality", "limits")
NOT_IN_ALL = ("dataset",)   # a pipeline of processes writing shards: run it alone (mane bench dataset)
STATS_KEYS = ("mean", "median", "p95", "min", "max", "n")
SKIP_KEYS = {"traceback", "settings", "renderer_stats", "warnings", "oit_bytes_detail", "settings_not_in_renderer",
             "series", "image", "oit_warnings", "gpu_ms_note"}


# --------------------------------------------------------------------------- targets
def targets(only=None) -> list[str]:
    """The targets ``all`` runs: TARGETS of ``mane bench`` but ``all``, in ORDER, whose module exists."""
    from .targets import TARGETS

    names = [t for t in ORDER if t in TARGETS] + [t for t in TARGETS if t not in ORDER + NOT_IN_ALL and t != "all"]
    out = []
    for t in names:
        if TARGETS[t][0] == __name__:
            continue
        try:
            if importlib.util.find_spec(TARGETS[t][0]) is None:
                continue
        except (ImportError, ValueError):
            continue
        out.append(t)
    if only:
        wanted = [w.strip() for w in (only.split(",") if isinstance(only, str) else only) if w.strip()]
        if wanted == ["none"]:      # run nothing: rebuild the files from DIR's JSON
            return []
        unknown = [w for w in wanted if w not in out]
        if unknown:
            from ..errors import UsageError

            raise UsageError(f"--only: unknown target(s) {', '.join(unknown)}; choose from {', '.join(out)}")
        out = [t for t in out if t in wanted]
    return out


def expected_tables(target: str) -> list[str]:
    """The CSV tables a target always gets (more if its rows name other sections)."""
    if target == "sim":
        from .sim_bench import Bench

        secs = list(Bench.SECTIONS)
        return secs[:2] + ["grid_friction"] + secs[2:]
    if target == "render":
        from .render_bench import SECTIONS

        return list(SECTIONS)
    if target == "oit":
        return ["methods", "memory", "target"]
    if target == "quality":
        return ["shading", "shadows", "oit", "simulation"]
    if target == "limits":
        from .limits import SECTIONS

        return list(SECTIONS)
    return ["results"]


def expected_sections(target: str) -> int:
    return {"sim": 6, "render": 9, "oit": 2, "quality": 4, "limits": 3}.get(target, 1)


# --------------------------------------------------------------------------- tables
def _is_stats(d) -> bool:
    return isinstance(d, dict) and "mean" in d and "n" in d


def flatten(row: dict, prefix: str = "", depth: int = 0) -> dict:
    """A row as {column: scalar}: nested dicts joined with '.', timing statistics cut to
    mean/median/p95/min/max/n, short lists of scalars joined with spaces, the rest left out."""
    out = {}
    for k, v in row.items():
        if k in SKIP_KEYS:
            continue
        key = f"{prefix}{k}"
        if _is_stats(v):
            for s in STATS_KEYS:
                out[f"{key}.{s}"] = v.get(s)
        elif isinstance(v, dict):
            if depth < 2:
                out.update(flatten(v, key + ".", depth + 1))
        elif isinstance(v, (list, tuple)):
            if len(v) <= 8 and all(isinstance(x, (int, float, str, bool)) or x is None for x in v):
                out[key] = "x".join(str(x) for x in v) if k == "size" else " ".join(str(x) for x in v)
        else:
            out[key] = v
    return out


def write_csv(path, rows: list[dict]) -> str:
    flat = [flatten(r) for r in rows]
    cols: list[str] = []
    for r in flat:
        for c in r:
            if c not in cols:
                cols.append(c)
    path = Path(path)
    from ..io.atomic import atomic_write_path

    with atomic_write_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols or ["status"], extrasaction="ignore")
        w.writeheader()
        for r in flat:
            w.writerow({c: _cell(r.get(c)) for c in cols})
    return str(path)


def _cell(v):
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return "" if v is None else v


def tables_of(target: str, result: dict) -> dict[str, list[dict]]:
    """{table name: rows} of a target's result."""
    out: dict[str, list[dict]] = {t: [] for t in expected_tables(target)}
    if not result or "error" in result and "meta" in result and len(result) <= 3:
        return out
    if target in ("sim", "render", "limits"):
        for r in result.get("results") or []:
            out.setdefault(r.get("bench", "results"), []).append(r)
    elif target == "oit":
        out["methods"] = list(result.get("methods") or [])
        out["memory"] = list(result.get("memory") or [])
        out["target"] = list((result.get("target") or {}).get("rows") or [])
    elif target == "quality":
        for name in expected_tables("quality"):
            sec = result.get(name) or {}
            if name == "shading":
                rows = sec.get("models") or []
            elif name in ("shadows", "oit"):
                rows = sec.get("methods") or []
            else:
                rows = [{"part": k, **v} for k, v in sec.items() if isinstance(v, dict) and k in ("scalp", "chain")]
            if not rows:
                rows = [{"status": sec.get("status", "not run"), "reason": sec.get("reason")}]
            out[name] = rows
    else:
        for k, v in result.items():
            if isinstance(v, list) and v and isinstance(v[0], dict):
                out.setdefault(k, []).extend(v)
    return out


# --------------------------------------------------------------------------- progress
class _Progress:
    """A tqdm bar over the targets' sections: a section counts when the target's progress
    messages ("[  1.2 s] section: config") move on to a new one."""

    def __init__(self, names: list[str], enabled: bool):
        from tqdm import tqdm

        self.expected = {t: expected_sections(t) for t in names}
        self.bar = tqdm(total=sum(self.expected.values()), desc="mane bench all", unit="section",
                        file=sys.stderr, disable=not enabled, dynamic_ncols=True, leave=True,
                        mininterval=0.2 if sys.stderr.isatty() else 10.0)
        self.enabled = enabled
        self.target = None
        self.seen: list[str] = []
        self.done_before = 0

    def start(self, target: str) -> None:
        self.target, self.seen = target, []
        self.bar.set_description(f"mane bench all: {target}")

    def message(self, msg: str) -> None:
        text = str(msg)
        body = text.split("] ", 1)[1] if text.startswith("[") and "] " in text else text
        section = body.split(":", 1)[0].strip() if ":" in body else None
        if section and section not in self.seen and len(section) < 40 and " " not in section.strip():
            self.seen.append(section)
            if len(self.seen) > 1 and len(self.seen) <= self.expected.get(self.target, 1):
                self.bar.update(1)
        self.bar.set_postfix_str(body[:70], refresh=True)

    def finish(self, target: str, status: str, seconds: float) -> None:
        self.done_before += self.expected.get(target, 1)
        self.bar.n = min(self.done_before, self.bar.total)
        self.bar.refresh()
        self.write(f"mane bench all: {target} {status} in {seconds:.1f} s")

    def write(self, text: str) -> None:
        if self.enabled:
            self.bar.write(text, file=sys.stderr)

    def close(self) -> None:
        self.bar.close()


# --------------------------------------------------------------------------- run
def _dump(path, obj) -> str:
    from ..io.atomic import atomic_write_path

    with atomic_write_path(path) as tmp:
        Path(tmp).write_text(to_json(sanitise(obj)) + "\n")
    return str(path)


def _rows_count(target: str, result: dict) -> dict:
    rows = []
    for t in tables_of(target, result).values():
        rows.extend(r for r in t if isinstance(r, dict) and "status" in r)
    out = {"ok": 0, "skipped": 0, "error": 0}
    for r in rows:
        s = r.get("status")
        if s in out:
            out[s] += 1
    return out


def run(ctx, mode: str = "default", progress=None, *, out_dir=None, only=None, baseline=None,
        bar: bool = False) -> dict:
    """Run every target (or ``only``); write DIR's files when ``out_dir`` is given. The index object.

    ``progress``: a callable for text lines (as the other targets take); ``bar``: a tqdm bar on
    stderr instead."""
    from .targets import TARGETS
    from . import plots as P
    from . import scaling as SC
    from . import seed_figures as SF
    from .common import envelope

    started = time.perf_counter()
    names = targets(only)
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        (out / "plots").mkdir(parents=True, exist_ok=True)
    prog = _Progress(names, enabled=bar)
    results: dict[str, dict] = {}
    index = {"targets": {}, "files": []}

    def note(path):
        if path and out is not None:
            try:
                index["files"].append(str(Path(path).resolve().relative_to(out.resolve())))
            except ValueError:   # outside DIR (an image path recorded by a run elsewhere)
                pass

    try:
        for name in names:
            prog.start(name)
            module = importlib.import_module(TARGETS[name][0])

            def cb(msg, name=name):
                prog.message(msg)
                if progress is not None:
                    progress(f"{name}: {msg}")

            kw = {}
            if name in ("quality", "fidelity") and out is not None:
                kw["image_dir"] = out / name
            t0 = time.perf_counter()
            try:
                res = sanitise(module.run(ctx, mode, progress=cb, **kw))
                status, reason = "ok", None
            except Exception as exc:   # the other targets still run
                status, reason = "error", f"{type(exc).__name__}: {exc}"
                res = {"meta": envelope(ctx, target=name, mode=mode), "error": reason,
                       "traceback": traceback.format_exc(limit=8)}
                prog.write(f"mane bench all: {name} failed: {reason}")
            secs = time.perf_counter() - t0
            results[name] = res
            entry = {"status": status, "reason": reason, "seconds": secs, "module": TARGETS[name][0],
                     "rows": _rows_count(name, res)}
            if out is not None:
                note(_dump(out / f"{name}.json", res))
                entry["json"] = f"{name}.json"
                entry["csv"] = []
                for table_name, rows in tables_of(name, res).items():
                    p = write_csv(out / f"{name}_{table_name}.csv", rows)
                    note(p)
                    entry["csv"].append(Path(p).name)
                if name == "quality":
                    for sec in res.values():
                        if isinstance(sec, dict) and sec.get("image"):
                            note(sec["image"])
            index["targets"][name] = entry
            prog.finish(name, status, secs)

        # targets not run now whose JSON is in DIR from an earlier run (--only): loaded, so that
        # runs split over several commands still give one summary and one set of plots
        if out is not None:
            for name in targets():
                path = out / f"{name}.json"
                if name in results or not path.is_file():
                    continue
                try:
                    res = json.loads(path.read_text())
                except (OSError, ValueError) as exc:
                    prog.write(f"mane bench all: {path} not loaded: {exc}")
                    continue
                if "error" in res and len(res) <= 3:
                    continue
                results[name] = res
                index["targets"][name] = {"status": "loaded", "reason": f"from {path.name} of an earlier run",
                                          "seconds": 0.0, "module": TARGETS[name][0],
                                          "rows": _rows_count(name, res), "json": path.name, "csv": []}
                note(str(path))
                for table_name, rows in tables_of(name, res).items():
                    p = write_csv(out / f"{name}_{table_name}.csv", rows)
                    note(p)
                    index["targets"][name]["csv"].append(Path(p).name)
                if name == "quality":
                    for sec in res.values():
                        if isinstance(sec, dict) and sec.get("image") and Path(sec["image"]).is_file():
                            note(sec["image"])
                prog.write(f"mane bench all: {name} loaded from {path}")

        fits = SC.scaling_fits(results)
        summary_fits = SC.summarise(fits)
        index["scaling"] = summary_fits
        comparison = _baseline_rows(results, baseline) if baseline else None
        from .limits import distance_rows

        index["distance_from_limits"] = distance_rows(results)
        if out is not None:
            note(write_csv(out / "scaling.csv", [{k: (" ".join(f"{x:.6g}" for x in v) if k in ("x", "y") else v)
                                                  for k, v in f.items()} for f in fits]))
            note(write_csv(out / "scaling_summary.csv", summary_fits))
            note(write_csv(out / "limits_distance.csv", index["distance_from_limits"]))
            note(write_csv(out / "seed_figures.csv", [
                {"figure": k, "seed": f["seed"], "hardware": f["hardware"], "unit": f["unit"], **p}
                for k, f in SF.as_dict().items() for p in f["points"]]))
            note(_dump(out / "seed_figures.json", SF.as_dict()))
            if comparison is not None:
                note(write_csv(out / "baseline_comparison.csv", comparison))
            prog.write("mane bench all: plots")
            written = P.write_all(results, fits, out / "plots")
            for path in written.values():
                if not str(path).startswith("error"):
                    note(path)
            index["plots"] = {k: (Path(v).name if not str(v).startswith("error") else v) for k, v in written.items()}
    finally:
        prog.close()

    meta_ctx = next((r.get("meta") for r in results.values() if isinstance(r, dict) and r.get("meta")), None)
    meta = envelope(ctx, target="all", mode=mode, settings={"targets": names, "only": only,
                                                            "baseline": str(baseline) if baseline else None},
                    timing={"total_seconds": time.perf_counter() - started})
    if meta_ctx:
        meta["gpu_memory"] = meta_ctx.get("gpu_memory", meta.get("gpu_memory"))
        if all(e.get("status") == "loaded" for e in index["targets"].values()):
            # --only none: the machine is the runs' (the JSON's), not the one rebuilding the files
            here = f"{meta['renderer']}, `{' '.join(meta['host']['argv'])}`"
            meta.update({k: meta_ctx[k] for k in ("date", "renderer", "vendor", "driver", "gl_version", "host",
                                                  "mane_version") if k in meta_ctx})
            meta["rebuilt_from_json_on"] = here
    index = {"meta": meta, **index}
    index["targets_met"] = _targets_met(results)
    if out is not None:
        from ..io.atomic import atomic_write_path

        with atomic_write_path(out / "summary.md") as tmp:
            tmp.write_text(summary_markdown(results, index, summary_fits, comparison))
        index["files"].append("summary.md")
        index["files"].append("all.json")
        index["files"] = sorted(set(index["files"]))
        _dump(out / "all.json", index)
    index["_results"] = results       # for format_text / callers; not in all.json
    return index


# --------------------------------------------------------------------------- baseline
def primary_ms(target: str, row: dict):
    """The one time a row is compared by (ms)."""
    from .scaling import render_ms

    def m(v):
        return v.get("mean") if isinstance(v, dict) else v

    if target == "sim":
        for key in ("step_ms", "apply_ms"):
            if row.get(key):
                return m(row[key])
        return row.get("total")
    if target == "render":
        return render_ms(row)
    if target == "oit":
        return m(row.get("frame_ms"))
    return None


def _baseline_rows(results: dict, baseline) -> list[dict]:
    base_dir = Path(baseline)
    rows = []
    for target in ("sim", "render", "oit"):
        path = base_dir / f"{target}.json"
        if target not in results or not path.is_file():
            continue
        try:
            base = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        key = (lambda r: (r.get("bench"), r.get("name"))) if target != "oit" else \
            (lambda r: (r.get("method"), r.get("shadows"), tuple(r.get("size") or ()), r.get("groom")))
        mine_rows = results[target].get("results") if target != "oit" else results[target].get("methods")
        base_rows = base.get("results") if target != "oit" else base.get("methods")
        bmap = {key(r): r for r in base_rows or [] if r.get("status") == "ok"}
        for r in mine_rows or []:
            b = bmap.get(key(r))
            if r.get("status") != "ok" or b is None:
                continue
            a_ms, b_ms = primary_ms(target, r), primary_ms(target, b)
            rows.append({"target": target, "section": r.get("bench", "methods"),
                         "configuration": r.get("name") or " ".join(str(x) for x in key(r)),
                         "ms": a_ms, "baseline_ms": b_ms,
                         "baseline_over_this": (b_ms / a_ms) if a_ms and b_ms else None,
                         "renderer": (results[target].get("meta") or {}).get("renderer"),
                         "baseline_renderer": (base.get("meta") or {}).get("renderer")})
    return rows


def _targets_met(results: dict) -> dict:
    out = {}
    sim = (results.get("sim") or {}).get("targets")
    if sim:
        out["sim"] = {k: sim.get(k) for k in ("full_solver_100k_x32_ms", "target_ms", "met", "note")}
    ren = (results.get("render") or {}).get("targets")
    if ren:
        out["render"] = {k: ren.get(k) for k in ("full_head_50k_ms", "target_ms", "met", "note")}
    oit = (results.get("oit") or {}).get("target")
    if oit:
        out["oit"] = oit.get("rows")
    return out


# --------------------------------------------------------------------------- summary.md
def _f(v, spec="{:.3f}"):
    from .common import fmt

    return fmt(v, spec)


def md_table(headers, rows) -> str:
    if not rows:
        return "(no rows)\n"
    out = ["| " + " | ".join(str(h) for h in headers) + " |", "|" + "---|" * len(headers)]
    for r in rows:
        out.append("| " + " | ".join("-" if c is None else str(c) for c in r) + " |")
    return "\n".join(out) + "\n"


def _machine(results: dict, target: str) -> str:
    m = (results.get(target) or {}).get("meta") or {}
    if not m:
        return f"*{target}: not run*\n"
    t = m.get("timing") or {}
    src = t.get("frame_source") or t.get("step_source") or t.get("frame") or t.get("source") or "-"
    return (f"*mane on {m.get('renderer')} ({m.get('vendor')}), driver {m.get('driver')}, OpenGL "
            f"{m.get('gl_version')}; `{m.get('mode')}` mode; timing: {src}.*\n")


def _ok(results, target, bench):
    return [r for r in (results.get(target) or {}).get("results") or []
            if r.get("bench") == bench and r.get("status") == "ok"]


def _m(v):
    return v.get("mean") if isinstance(v, dict) else v


def _seed(fig, x, series):
    return next((p.y for p in fig.points if p.x == x and p.series == series), None)


def _limits_section(results: dict, index: dict) -> list[str]:
    """summary.md's "Distance from the hardware limits": the limits measured by ``mane bench
    limits`` and each stage's fraction of them (``limits.distance_rows``)."""
    from .limits import distance_rows, peaks_of

    L = ["", "## Distance from the hardware limits", ""]
    lim = results.get("limits") or {}
    rows = index.get("distance_from_limits")
    rows = distance_rows(results) if rows is None else rows
    if lim.get("results"):
        peaks = lim.get("peaks") or peaks_of(lim["results"])
        L += [_machine(results, "limits"),
              "The limits, measured on this GPU by `mane bench limits` (`limits.json`: each row's `method` says how; "
              "the figure is from the fastest of the timed runs):", ""]
        lrows = []
        for r in lim["results"]:
            if r.get("status") != "ok":
                continue
            if r["bench"] == "dram":
                lrows.append(["DRAM, streaming copy", f"{_f(r['value'], '{:.1f}')} GB/s (read + written)",
                              f"{r['buffer_bytes'] >> 20} MiB buffers, median {_f(r['value_median'], '{:.1f}')}"])
            elif r["bench"] == "raster":
                lrows.append([f"raster units, {r['msaa']}x MSAA",
                              f"{_f(r['triangles_per_s'] / 1e9, '{:.4g}')} G triangles/s, "
                              f"{_f(r['samples_per_s'] / 1e9, '{:.4g}')} G samples/s",
                              f"{r['triangles']} triangles of {r['triangle_pixels']:g} px at "
                              f"{r['size'][0]}x{r['size'][1]}, trivial fragment shader"])
            elif r["bench"] == "atomics":
                where = "random words" if r["pattern"] == "random" else "consecutive words a thread"
                lrows.append([f"atomicMin {r['bits']}-bit, {where}",
                              f"{_f(r['value'] / 1e9, '{:.4g}')} G operations/s",
                              f"{r['ops']} operations into {r['words']} words (1920x1080x4 samples)"])
        if peaks.get("dram_tabulated_GBps"):
            lrows.append([f"DRAM, tabulated peak ({peaks.get('dram_tabulated_model')})",
                          f"{peaks['dram_tabulated_GBps']:.0f} GB/s", "mane.bench.common.PEAK_DRAM_BANDWIDTH"])
        L.append(md_table(["limit", "measured", "how"], lrows))
        skipped = [f"{r['name']} ({r.get('reason')})" for r in lim["results"] if r.get("status") != "ok"]
        if skipped:
            L += [f"Not measured here: {'; '.join(skipped)}.", ""]
    else:
        L += ["The limits were not measured in this run (`mane bench all --only limits` measures them); the solver "
              "is compared with the tabulated DRAM peak only.", ""]
    bw = (results.get("sim") or {}).get("bandwidth") or {}
    if bw.get("achieved_GBps") is None:
        L += [f"Solver DRAM bandwidth: {bw.get('note', 'not measured')}.", ""]
    shown = [r for r in rows if r["stage"] == "solver" or r.get("section") in ("target", "target_rasterizer")]
    L += ["Each stage against its limit (fraction = achieved / measured limit; all render rows in "
          "`limits_distance.csv`):", ""]
    L.append(md_table(["stage", "path", "configuration", "achieved", "measured limit", "fraction",
                       "tabulated limit", "fraction of tabulated"],
                      [[r["stage"], r["path"],
                        f"{r.get('configuration')}" + (f", msaa {r['msaa']}" if r.get("msaa") else ""),
                        f"{_f(r['achieved'], '{:.4g}')} {r['unit']}", _f(r.get("limit"), "{:.4g}"),
                        _f(None if r.get("fraction") is None else 100 * r["fraction"], "**{:.1f}%**"),
                        _f(r.get("tabulated_limit"), "{:.4g}"),
                        _f(None if r.get("tabulated_fraction") is None else 100 * r["tabulated_fraction"], "{:.1f}%")]
                       for r in shown]))
    est = [r for r in shown if r.get("samples_per_s") is not None]
    if est:
        L += ["", "Hardware hair pass, samples (estimated: the compute rasteriser's sample visits of the same "
              "strands, times the pass's draws):", ""]
        L.append(md_table(["configuration", "samples / frame", "samples/s", "measured limit", "fraction"],
                          [[r["configuration"], r["samples_estimated"], _f(r["samples_per_s"], "{:.4g}"),
                            _f(r.get("samples_limit"), "{:.4g}"),
                            _f(None if r.get("samples_fraction") is None else 100 * r["samples_fraction"], "{:.1f}%")]
                           for r in est]))
    comp = [r for r in shown if r["path"].startswith("compute")]
    if comp:
        L += ["", "Compute rasteriser (one extra frame with hair_raster.comp's RASTER_STATS counters): "
              + "; ".join(f"{r['configuration']}: {r['sample_visits']} samples scanned, {r['sample_writes']} in "
                          f"front of the head, {r['atomics']} atomics in {_f(r['time_ms'], '{:.4f}')} ms "
                          f"({r['time_source']}), "
                          + _f(None if r.get("fraction_sequential") is None else 100 * r["fraction_sequential"],
                               "{:.1f}%") + " of the consecutive-word atomicMin figure" for r in comp)
              + ". The rasteriser walks neighbouring samples, so it can beat the random-address limit.", ""]
    return L


def summary_markdown(results: dict, index: dict, fits: list[dict], comparison=None) -> str:
    from . import seed_figures as SF
    from .scaling import render_ms

    meta = index["meta"]
    L = [f"# mane bench all ({meta['mode']})", "",
         f"{meta['date']}, mane {meta['mane_version']}, on **{meta['renderer']}** ({meta['vendor']}), driver "
         f"**{meta['driver']}**, OpenGL {meta['gl_version']}; GPU memory: "
         f"{(meta.get('gpu_memory') or {}).get('total')} B ({(meta.get('gpu_memory') or {}).get('source')}); host "
         f"{meta['host']['platform']}, {meta['host']['cpu_count']} CPUs; "
         f"`{' '.join(meta['host']['argv'])}`."
         + (f" These files were rebuilt from the runs' JSON on {meta['rebuilt_from_json_on']}."
            if meta.get("rebuilt_from_json_on") else ""), "",
         "Times are milliseconds: GPU timestamps on GPUs, CPU wall time with `ctx.finish()` on software renderers "
         "(each target's JSON `meta.timing` says which). Published values are the seeds' own, on their hardware "
         "(`seed_figures.csv` gives the source of each; '~' marks values read by eye from a chart or derived "
         "from FPS).", ""]
    L.append(md_table(["target", "status", "seconds", "ok", "skipped", "error"],
                      [[t, e["status"] + (f" ({e['reason']})" if e.get("reason") else ""), f"{e['seconds']:.1f}",
                        e["rows"]["ok"], e["rows"]["skipped"], e["rows"]["error"]]
                       for t, e in index["targets"].items()]))

    # ---- Woodhouse
    L += ["## Woodhouse (2017) Tables 5.1 and 5.2", "", _machine(results, "sim"),
          "Simulation components on his workload (242 strands x 8 particles, and smoothed to 16), 25^3 voxels; "
          f"published: {SF.WOODHOUSE_T52.hardware}.", ""]
    rows = []
    for r in _ok(results, "sim", "woodhouse"):
        c = r.get("categories_ms") or {}
        rows.append([f"mane {r['name']}", _f(c.get("strand_dynamics")), _f(c.get("clear_voxels")),
                     _f(c.get("voxel_calculations")), _f(_m(r.get("step_ms")))])
    for s in SF.WOODHOUSE_T52.series():
        rows.append([f"Woodhouse {s}", _seed(SF.WOODHOUSE_T52, "strand dynamics", s),
                     _seed(SF.WOODHOUSE_T52, "clear voxels", s), _seed(SF.WOODHOUSE_T52, "voxel calculations", s),
                     _seed(SF.WOODHOUSE_T51, s.split()[0], "sim " + s.split()[1])])
    L.append(md_table(["", "strand dynamics", "clear voxels", "voxel calculations", "whole sim step"], rows))
    L += ["", "Draw (render frame) with 4x MSAA / without, his workload (Sadeghi shading):", "",
          _machine(results, "render")]
    rows = []
    aa: dict = {}
    for r in _ok(results, "render", "woodhouse_msaa"):
        aa.setdefault(f"mane {r.get('shadows')} (his {r.get('version')})", {})[r.get("msaa")] = render_ms(r)
    for k, v in aa.items():
        rows.append([k, _f(v.get(4)), _f(v.get(1))])
    for s in SF.WOODHOUSE_T52.series():
        rows.append([f"Woodhouse {s}", _seed(SF.WOODHOUSE_T52, "draw msaa 4", s),
                     _seed(SF.WOODHOUSE_T52, "draw msaa 1", s)])
    L.append(md_table(["", "4x MSAA", "no MSAA"], rows))
    full = [r for r in _ok(results, "sim", "full_solver") if r.get("grid_method") == "atomic"]
    tgt = _ok(results, "render", "target")
    if full or tgt:
        L += ["", "Full-head workload:", ""]
        L.append(md_table(["", "configuration", "ms"],
                          [["sim step", r["name"], _f(_m(r.get("step_ms")))] for r in full]
                          + [["render frame", r["name"] + f", msaa {r.get('msaa')}", _f(render_ms(r))] for r in tgt]))

    # ---- Chen
    L += ["", "## Chen (2011) Tables 2-5", "", _machine(results, "sim"),
          f"FLIP volume pass, GPU (Jacobi PCG) against the NumPy solver of the same method; published: "
          f"{SF.CHEN_T2.hardware} (his FPS are of the whole simulation, his CPU solver uses MIC PCG).", ""]
    rows = []
    shares = {r["resolution"]: r for r in _ok(results, "sim", "chen_shares")}
    for r in sorted(_ok(results, "sim", "flip"), key=lambda r: (r["strands"], r["resolution"])):
        R = r["resolution"]
        cpu = (r.get("cpu_ms") or {}).get("median")
        rows.append([r["name"], _f(_m(r.get("apply_ms"))), _f(cpu, "{:.1f}"), _f(r.get("speedup"), "{:.1f}x"),
                     _f(r.get("pcg_iterations"), "{:.0f}"), r.get("cpu_pcg_iterations"),
                     _f((shares.get(R) or {}).get("fps"), "{:.0f}") if r["strands"] == 1750 else None,
                     _seed(SF.CHEN_T2, R, "GPU"), _seed(SF.CHEN_T2, R, "CPU"),
                     _f(_seed(SF.CHEN_T2_SPEEDUP, R, "speed-up"), "{:.1f}x")])
    L.append(md_table(["grid (workload)", "GPU ms", "NumPy ms", "speed-up", "PCG it GPU", "PCG it CPU",
                       "mane step FPS (volume on)", "Chen GPU FPS", "Chen CPU FPS", "Chen speed-up"], rows))
    L += ["", "Share of each FLIP stage (GPU):", ""]
    stages = ("p2g", "classify", "divergence", "pcg", "gradient", "g2p")
    L.append(md_table(["grid"] + list(stages),
                      [[r["name"]] + [_f(100 * ((r.get("stage_share") or {}).get(s) or 0), "{:.1f}%") for s in stages]
                       for r in _ok(results, "sim", "flip")]))
    L += ["", "Table 4: share of a simulation step with the volume method on:", ""]
    cats = ("solving_constraints", "volume_method", "force_velocity_position")
    rows = [[f"mane {r['name']}"] + [_f(100 * ((r.get("share") or {}).get(c) or 0), "{:.1f}%") for c in cats]
            for r in sorted(shares.values(), key=lambda r: r["resolution"])]
    rows += [[f"Chen {s} (32^3)"] + [f"{_seed(SF.CHEN_T4, c, s)}%" for c in cats] for s in SF.CHEN_T4.series()]
    L.append(md_table(["", "constraints", "volume", "force/velocity/position"], rows))
    L += ["", "Table 5: FPS against viewing distance (mane: x the framing distance; Chen: units not given), LOD "
          f"on / off; published: {SF.CHEN_T5.hardware}.", "", _machine(results, "render")]
    grid: dict = {}
    for r in _ok(results, "render", "chen_lod"):
        grid.setdefault((r.get("resolution"), r.get("distance")), {})[r.get("lod")] = r.get("fps")
    L.append(md_table(["resolution", "distance", "mane FPS LOD on", "mane FPS LOD off", "Chen FPS (same resolution)"],
                      [[res, d, _f(v.get("on"), "{:.1f}"), _f(v.get("off"), "{:.1f}"), _seed(SF.CHEN_T5, d, res)]
                       for (res, d), v in sorted(grid.items(), key=lambda kv: (str(kv[0][0]), kv[0][1]))]))

    # ---- Hunz
    L += ["", "## Hunz (2016) Figs. 33, 36, 41, 42", "", _machine(results, "render"),
          "Fig. 33, ms per frame (one light, no shadows, GL_LINES); Hunz published no values outside the chart.", ""]
    sh: dict = {}
    models = []
    for r in _ok(results, "render", "hunz_shading"):
        sh.setdefault(r.get("rendered_strands"), {})[r.get("shading")] = render_ms(r)
        if r.get("shading") not in models:
            models.append(r.get("shading"))
    L.append(md_table(["strands"] + models, [[s] + [_f(v.get(m)) for m in models] for s, v in sorted(sh.items())]))
    L += ["", "Fig. 36, ms per frame: shadow method x map size x PCF (published, GTX 960: DOM ~6.3 ms and ADSM "
          "~3.3 ms at 256^2 with 3x3 PCF).", ""]
    shd: dict = {}
    sizes = []
    for r in _ok(results, "render", "hunz_shadows"):
        key = (r.get("shadows"), r.get("pcf"))
        shd.setdefault(key, {})[r.get("shadow_map_size")] = render_ms(r)
        if r.get("shadow_map_size") not in sizes:
            sizes.append(r.get("shadow_map_size"))
    sizes = sorted(s for s in sizes if s)
    L.append(md_table(["method", "pcf"] + [f"{s}^2" for s in sizes] + ["no map"],
                      [[m, p] + [_f(v.get(s)) for s in sizes] + [_f(v.get(None))] for (m, p), v in shd.items()]))
    oit = results.get("oit") or {}
    L += ["", "Fig. 41, ms per frame: OIT method x shadow method (straight groom); published (GTX 960, 656x861, "
          "ms from the FPS in the text).", "", _machine(results, "oit")]
    orows = [r for r in oit.get("methods") or [] if r.get("status") == "ok" and r.get("groom") == "straight"]
    shadows = list(dict.fromkeys(r["shadows"] for r in orows))
    ot: dict = {}
    for r in orows:
        ot.setdefault((r["method"], f"{r['size'][0]}x{r['size'][1]}"), {})[r["shadows"]] = _m(r.get("frame_ms"))
    L.append(md_table(["method", "size"] + shadows + ["Hunz DOM", "Hunz ADSM"],
                      [[m, size] + [_f(v.get(s)) for s in shadows]
                       + [_f(_seed(SF.HUNZ_F41, m, "deep_opacity"), "~{:.1f}"), _f(_seed(SF.HUNZ_F41, m, "adsm"),
                                                                                   "~{:.1f}")]
                       for (m, size), v in ot.items()]))
    L += ["", "Fig. 42, memory (MiB):", ""]
    L.append(md_table(["method", "size", "mane MiB", "fragments / pixel", "Hunz MiB (656x861)"],
                      [[r["method"], f"{r['size'][0]}x{r['size'][1]}", _f(r.get("oit_mib"), "{:.2f}"),
                        _f(r.get("fragments_per_pixel"), "{:.1f}"), _seed(SF.HUNZ_F42, r["method"].split("/")[0],
                                                                          "656x861")]
                       for r in oit.get("memory") or []]))

    # ---- Vulkan
    L += ["", "## The Vulkan project's four charts", "", _machine(results, "render"),
          f"FPS of pipelined frames; published: {SF.VULKAN_GUIDES.hardware}, values read by eye from the charts "
          "(approximate).", ""]
    for bench, fig, label in (("vulkan_guides", SF.VULKAN_GUIDES, "guides"),
                              ("vulkan_divisions", SF.VULKAN_DIVISIONS, "divisions"),
                              ("vulkan_strands_per_guide", SF.VULKAN_SPG, "strands per guide"),
                              ("vulkan_pcf", SF.VULKAN_PCF, "PCF taps")):
        rows = sorted(_ok(results, "render", bench), key=lambda r: r.get("parameter") or 0)
        L += [f"{fig.title}:", ""]
        L.append(md_table([label, "mane FPS", "mane 1000 / GPU ms", "published FPS (~)"],
                          [[r.get("parameter"), _f(r.get("fps"), "{:.1f}"), _f(r.get("gpu_fps"), "{:.1f}"),
                            _seed(fig, r.get("parameter"), "fps")] for r in rows]))
        L.append("")

    # ---- targets, scaling, limits
    L += ["## Targets", ""]
    for k, v in index.get("targets_met", {}).items():
        L.append(f"- {k}: `{json.dumps(v, default=str)[:400]}`")
    L += ["", "## How time scales (t = c x^k, least squares on logs)", "",
          "Exponent near 1: time in proportion (throughput-bound); near 0: fixed costs dominate. With two points "
          "R^2 is 1 by construction. All fits: `scaling.csv`.", ""]
    L.append(md_table(["variable", "target", "series", "groups", "k median", "k range", "min R^2", "points"],
                      [[f["variable"], f["target"], f["series"], f["groups"], f"{f['exponent_median']:.2f}",
                        f"{f['exponent_min']:.2f} .. {f['exponent_max']:.2f}", f"{f['r2_min']:.3f}", f["points"]]
                       for f in fits]))
    L += _limits_section(results, index)
    # ---- quality
    q = results.get("quality")
    if q:
        L += ["", "## Quality: the validation figures", "", _machine(results, "quality")]
        s = q.get("shading") or {}
        if s.get("status") == "ok":
            L.append(md_table(["model", "against", "max rel. error", "p95 rel. error", "max |err| / peak"],
                              [[r["model"], r.get("against"), _f(r.get("max_rel_error"), "{:.2e}"),
                                _f(r.get("p95_rel_error"), "{:.2e}"), _f(r.get("max_abs_over_peak"), "{:.2e}")]
                               for r in s.get("models") or []]))
        else:
            L.append(f"shading: {s.get('status')}: {s.get('reason')}\n")
        s = q.get("shadows") or {}
        if s.get("status") == "ok":
            L += ["", f"Shadows against the exact ray cast ({s.get('setup')}):", ""]
            L.append(md_table(["method", "mean abs error", "bias", "max abs error"],
                              [[r["method"], _f(r.get("mean_abs_error"), "{:.4f}"), _f(r.get("bias"), "{:+.4f}"),
                                _f(r.get("max_abs_error"), "{:.3f}")] for r in s.get("methods") or []]))
        else:
            L.append(f"shadows: {s.get('status')}: {s.get('reason')}\n")
        s = q.get("oit") or {}
        if s.get("status") == "ok":
            L += ["", f"OIT against the exact sort ({s.get('setup')}; {s.get('fragments')} fragments, up to "
                  f"{s.get('max_depth')} a pixel), differences in 1/255:", ""]
            L.append(md_table(["method", "mean", "p99", "max", "pixels > 1/255"],
                              [[r["method"], _f((r.get("mean") or 0) * 255, "{:.2f}"),
                                _f((r.get("p99") or 0) * 255, "{:.1f}"), _f((r.get("max") or 0) * 255, "{:.0f}"),
                                r.get("pixels_over_1_255")] for r in s.get("methods") or []]))
        else:
            L.append(f"OIT: {s.get('status')}: {s.get('reason')}\n")
        s = q.get("simulation") or {}
        if s.get("status") == "ok":
            sc, ch = s["scalp"], s["chain"]
            L += ["", f"Simulation invariants ({sc['strands']} x {sc['points']} strands, {sc['steps']} steps nodding): "
                  f"max length error {_f(sc['max_length_error_m'], '{:.2e}')} m, root error "
                  f"{_f(sc['max_root_error_m'], '{:.2e}')} m, penetration {_f(sc['max_penetration_m'], '{:.2e}')} m, "
                  f"NaN recoveries {sc['nan_recoveries']}; a chain settles to direction y = "
                  f"{_f(ch['final_direction_y'], '{:.4f}')}, kinetic energy (last quarter / peak) "
                  f"{_f(ch['energy_last_quarter_over_peak'], '{:.1e}')}.", ""]
        else:
            L.append(f"simulation: {s.get('status')}: {s.get('reason')}\n")
        L.append("Images: " + ", ".join(f"`quality/{n}.png`" for n in ("shading", "shadows", "oit", "simulation")))
    if comparison:
        L += ["", "## Against the baseline run", "",
              f"Same configurations in `--baseline` ({comparison[0]['baseline_renderer']}), ms:", ""]
        L.append(md_table(["target", "section", "configuration", "this run", "baseline", "baseline / this"],
                          [[c["target"], c["section"], c["configuration"], _f(c["ms"]), _f(c["baseline_ms"]),
                            _f(c["baseline_over_this"], "{:.1f}x")] for c in comparison]))
    # ---- skipped
    bad = []
    for t, res in results.items():
        for name, rows in tables_of(t, res).items():
            for r in rows:
                if isinstance(r, dict) and r.get("status") in ("skipped", "error"):
                    bad.append([t, name, r.get("name") or r.get("method") or r.get("model") or "",
                                r["status"], str(r.get("reason"))[:160].replace("|", "/")])
    L += ["", "## Skipped and failed configurations", ""]
    L.append(md_table(["target", "table", "configuration", "status", "reason"], bad) if bad else "None.\n")
    L += ["", "## Files", "", ", ".join(f"`{f}`" for f in index.get("files", [])), ""]
    return "\n".join(L)


# --------------------------------------------------------------------------- text / CLI
def format_text(result: dict) -> str:
    meta = result.get("meta", {})
    out = [f"mane bench all ({meta.get('mode')}) on {meta.get('renderer')} [{meta.get('driver')}]"]
    from .common import table

    rows = [{"target": t, **e, **e["rows"]} for t, e in result.get("targets", {}).items()]
    out.append(table(rows, [("target", "target", "{}"), ("status", "status", "{}"), ("seconds", "seconds", "{:.1f}"),
                            ("ok", "ok", "{}"), ("skipped", "skipped", "{}"), ("error", "error", "{}")]))
    if result.get("scaling"):
        out.append(table(result["scaling"], [("variable", "variable", "{}"), ("target", "target", "{}"),
                                             ("series", "series", "{}"), ("k median", "exponent_median", "{:.2f}"),
                                             ("min R^2", "r2_min", "{:.3f}")], title="\nscaling exponents"))
    if result.get("files"):
        out.append(f"\n{len(result['files'])} files written")
    return "\n".join(out)


def run_cli(args) -> int:
    """``mane bench all``: --out DIR (default ./mane-bench), --quick / --full, --only, --baseline, --json."""
    from ..gpu import get_context

    mode = "quick" if args.quick else "full" if args.full else "default"
    out_dir = Path(args.out or "mane-bench")
    result = run(get_context(), mode, None, out_dir=out_dir, only=getattr(args, "only", None),
                 baseline=getattr(args, "baseline", None), bar=not args.quiet)
    result.pop("_results", None)
    if args.json:
        print(to_json(sanitise(result)))
    else:
        print(format_text(result))
        print(f"\nwritten to {out_dir}/: summary.md, all.json, <target>.json, *.csv, plots/*.png, quality/*.png")
    return 0 if all(e["status"] in ("ok", "loaded") for e in result["targets"].values()) else 1


__all__ = ["run", "run_cli", "format_text", "targets", "flatten", "write_csv", "tables_of", "summary_markdown",
           "ORDER"]
