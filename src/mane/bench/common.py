"""Shared benchmark pieces: the JSON envelope (``meta``) and writer (``sanitise``, ``to_json``), timing loops and statistics, rows, tables.

    meta = envelope(ctx, target="sim", mode="quick", settings={...}, timing={...})
    wall, submit = time_each(ctx, sim.step, 30, prof, "step")   # ms lists, ctx.finish() around each
    per_ms = time_pipelined(ctx, sim.step, 30)                  # back to back, one finish
    stats(samples_ms)        # {"mean": .., "median": .., "p95": .., "min": .., "max": .., "n": ..}
    print(table(rows, [("strands", "{:d}"), ("step ms", "{:.3f}")]))
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import sys
import time
import traceback
from contextlib import contextmanager
from pathlib import Path

from ..errors import GLFeatureError, GPUMemoryError, UsageError


class Skip(Exception):
    """A configuration that cannot be measured here (too slow for the budget, unsupported setting, ...)."""

# Peak DRAM bandwidth, bytes/s, by GPU model (the part of GL_RENDERER before the first '/').
# NVIDIA's renderer strings end in "/PCIe/SSE2" whatever the board, so the bus suffix is
# ignored; the model part says "PCIe" only for PCIe boards ("NVIDIA H100 PCIe").
# Checked in order: the first (substring, peak) whose substring is in the model wins.
PEAK_DRAM_BANDWIDTH = (
    ("GH200", 4.0e12),           # Grace Hopper (HBM3 96 GB)
    ("H200", 4.8e12),            # H200 SXM / NVL: HBM3e 4.8 TB/s
    ("H100 NVL", 3.9e12),
    ("H100 PCIe", 2.0e12),
    ("H100", 3.35e12),           # H100 SXM5 80GB HBM3
    ("A100-SXM4-80GB", 2.039e12),
    ("A100 80GB PCIe", 1.935e12),
    ("A100", 1.555e12),          # 40 GB
    ("L40S", 0.864e12),
    ("RTX 4090", 1.008e12),
)


def peak_bandwidth(renderer: str) -> tuple[float | None, str | None]:
    """(bytes/s, the table key that matched) for a GL_RENDERER string, or (None, None)."""
    model = str(renderer).split("/")[0]
    for key, peak in PEAK_DRAM_BANDWIDTH:
        if key in model:
            return peak, key
    return None, None


def stats(samples) -> dict:
    """mean, median, p95, min, max (same unit as the samples) and n; None values when empty."""
    xs = sorted(float(x) for x in samples if x is not None and math.isfinite(float(x)))
    if not xs:
        return {"mean": None, "median": None, "p95": None, "min": None, "max": None, "n": 0}
    n = len(xs)

    def quantile(q: float) -> float:
        pos = q * (n - 1)
        lo = int(math.floor(pos))
        hi = min(lo + 1, n - 1)
        return xs[lo] + (xs[hi] - xs[lo]) * (pos - lo)

    return {"mean": sum(xs) / n, "median": quantile(0.5), "p95": quantile(0.95),
            "min": xs[0], "max": xs[-1], "n": n}


def time_each(ctx, fn, n: int, prof=None, section: str | None = None) -> tuple[list, list]:
    """Run ``fn()`` ``n`` times, each between two ``ctx.finish()`` (inside ``prof.section(section)``
    when a profiler is given): (wall ms, submit ms) lists; submit is the CPU time to issue it."""
    wall, submit = [], []
    for _ in range(n):
        ctx.finish()
        t = time.perf_counter()
        if prof is None:
            fn()
        else:
            with prof.section(section):
                fn()
        submit.append((time.perf_counter() - t) * 1e3)
        ctx.finish()
        wall.append((time.perf_counter() - t) * 1e3)
    return wall, submit


def time_pipelined(ctx, fn, n: int) -> float:
    """Milliseconds per ``fn()`` over ``n`` runs back to back, one ``ctx.finish()`` at the end."""
    ctx.finish()
    t = time.perf_counter()
    for _ in range(n):
        fn()
    ctx.finish()
    return (time.perf_counter() - t) * 1e3 / n


class BenchRows:
    """The rows and progress log of a benchmark: a subclass sets ``rows``, ``started`` and ``progress``.

    ``_guard`` runs one configuration: on a known failure (out of GPU memory, a missing GL
    feature, one of ``skip_errors``) it adds a skipped row, on any other an error row, and goes on."""

    skip_errors: tuple = (Skip,)
    traceback_limit = 4
    reason_limit: int | None = None    # longer error reasons are cut, with " ..."

    def _start(self, ctx, mode: str, modes: dict, progress=None, *, profiler_source: str | None = None,
               history: int = 1_000_000) -> None:
        """What every benchmark sets first: ctx, mode (one of ``modes``), progress, a GPU profiler
        (``profiler_source`` None: timer queries on GPUs, the CPU on llvmpipe), rows, started."""
        from ..gpu.profiler import GpuProfiler

        if mode not in modes:
            raise ValueError(f"unknown mode {mode!r}; one of {', '.join(modes)}")
        self.ctx, self.mode = ctx, mode
        self.progress = progress or (lambda msg: None)
        self.prof = GpuProfiler(ctx, history=history, pool_size=64, source=profiler_source, every=1)
        self.rows: list[dict] = []
        self.started = time.perf_counter()

    def _log(self, msg: str) -> None:
        self.progress(f"[{time.perf_counter() - self.started:7.1f} s] {msg}")

    def _row(self, bench: str, name: str, **fields) -> dict:
        row = {"bench": bench, "name": name, "status": "ok", "reason": None, **fields}
        self.rows.append(row)
        return row

    def _skip_row(self, bench: str, name: str, reason: str, status: str = "skipped", **fields) -> dict:
        row = self._row(bench, name, **fields)
        row.update(status=status, reason=reason)
        return row

    def _before_config(self) -> None:
        """Called first inside a configuration's guarded body (raise Skip to pass it over: a
        guard cannot skip its body from before its yield, a generator that never yields breaks)."""

    @contextmanager
    def _guard(self, bench: str, name: str, **fields):
        """Run a configuration; on a known failure add a skipped row and go on."""
        self._log(f"{bench}: {name}")
        try:
            yield
        except GPUMemoryError as exc:
            self._skip_row(bench, name, f"out of GPU memory: {exc}", **fields)
        except GLFeatureError as exc:
            self._skip_row(bench, name, f"missing GL feature: {exc}", **fields)
        except self.skip_errors as exc:
            self._skip_row(bench, name, str(exc), **fields)
        except Exception as exc:  # a benchmark goes on; the row says what broke
            reason = f"{type(exc).__name__}: {exc}"
            if self.reason_limit is not None and len(reason) > self.reason_limit:
                reason = reason[:self.reason_limit] + " ..."
            self._skip_row(bench, name, reason, status="error", **fields,
                           traceback=traceback.format_exc(limit=self.traceback_limit))
            self._log(f"  error: {type(exc).__name__}: {exc}")


def _versions() -> dict:
    out = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "moderngl"):
        try:
            mod = __import__(name)
            out[name] = str(getattr(mod, "__version__", "?"))
        except Exception:
            out[name] = None
    return out


def _json_default(obj):
    import numpy as np

    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (set, frozenset, tuple)):
        return list(obj)
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def to_json(result: dict) -> str:
    """Strict JSON (``sanitise`` first: NaN is refused), 2-space indent; NumPy values as numbers and lists."""
    return json.dumps(result, indent=2, default=_json_default, allow_nan=False)


def write_result(out_dir, name: str, text: str) -> None:
    """``text`` (a result's JSON) as ``out_dir/name``, written atomically (out_dir made)."""
    from pathlib import Path

    from ..io.atomic import atomic_write_path

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write_path(out_dir / name) as tmp:
        Path(tmp).write_text(text + "\n")


def sanitise(obj):
    """NaN / inf -> None, so the JSON is strict."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: sanitise(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [sanitise(v) for v in obj]
    return obj


# NVIDIA's driver thread (CPU issue: docs/performance.md, "The driver's own thread") and shader
# cache (cold starts), Mesa's shader cache
DRIVER_ENV = ("__GL_THREADED_OPTIMIZATIONS", "__GL_SHADER_DISK_CACHE", "MESA_SHADER_CACHE_DISABLE")


def envelope(ctx, *, target: str, mode: str, settings: dict | None = None,
             timing: dict | None = None) -> dict:
    """The ``meta`` object every benchmark's JSON starts with."""
    from .. import __version__

    info = {}
    try:
        info = dict(ctx.info)
    except Exception:
        pass
    meta = {
        "benchmark": target,
        "mode": mode,
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "mane_version": __version__,
        "renderer": str(info.get("GL_RENDERER", "unknown")),
        "vendor": str(info.get("GL_VENDOR", "unknown")),
        "gl_version": str(info.get("GL_VERSION", "unknown")),
        "driver": None,
        "software_renderer": None,
        "gpu_memory": None,
        "host": {"platform": platform.platform(), "cpu_count": os.cpu_count(),
                 "argv": list(sys.argv),
                 # driver settings that change the figures, as this run had them (None: unset)
                 "driver_env": {k: os.environ.get(k) for k in DRIVER_ENV}},
        "versions": _versions(),
        "settings": dict(settings or {}),
        "timing": dict(timing or {}),
    }
    # the driver is the part of GL_VERSION after the profile: "4.6.0 NVIDIA 550.54" -> "NVIDIA 550.54",
    # "4.5 (Core Profile) Mesa 23.2.1" -> "Mesa 23.2.1"
    version = meta["gl_version"]
    rest = version.split(")", 1)[1] if ")" in version else " ".join(version.split()[1:])
    meta["driver"] = rest.strip() or None
    try:
        from ..gpu.capabilities import get_capabilities

        caps = get_capabilities(ctx)
        meta["software_renderer"] = bool(caps.is_software)
        meta["gpu_memory"] = caps.memory.as_dict()
        meta["glsl_version"] = caps.glsl_version
    except Exception as exc:  # capabilities are informative only
        meta["gpu_memory"] = {"total": None, "available": None, "source": f"unavailable ({exc})"}
    return meta


def title_line(meta: dict) -> str:
    """The first line of every benchmark's text output: what ran, where, with which driver."""
    return (f"mane {meta.get('mane_version')} bench {meta.get('benchmark')} ({meta.get('mode')}) on "
            f"{meta.get('renderer')} [{meta.get('vendor')}, OpenGL {meta.get('gl_version')}]")


def fmt(value, spec: str = "{:.3f}", missing: str = "-") -> str:
    if value is None:
        return missing
    if isinstance(value, float) and not math.isfinite(value):
        return missing
    try:
        return spec.format(value)
    except (ValueError, TypeError):
        return str(value)


def table(rows: list[dict], columns: list[tuple], title: str | None = None, indent: str = "  ") -> str:
    """An aligned text table. columns: (header, key or callable(row), format spec)."""
    cells = []
    for row in rows:
        line = []
        for header, key, spec in columns:
            value = key(row) if callable(key) else row.get(key)
            line.append(value if isinstance(value, str) else fmt(value, spec))
        cells.append(line)
    headers = [c[0] for c in columns]
    widths = [max([len(h)] + [len(r[i]) for r in cells]) for i, h in enumerate(headers)]
    out = []
    if title:
        out.append(title)
    out.append(indent + "  ".join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(headers, widths))))
    out.append(indent + "  ".join("-" * w for w in widths))
    for line in cells:
        out.append(indent + "  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(line, widths))))
    if not rows:
        out.append(indent + "(none)")
    return "\n".join(out)


def stat_of(key: str, which: str):
    """A table column: ``row[key][which]`` (a ``stats`` entry), None where missing."""
    return lambda r: (r.get(key) or {}).get(which)


def failures_table(rows: list[dict]) -> str | None:
    """The "Skipped / failed" table of the rows whose status is not ok, or None when all are."""
    bad = [r for r in rows if r["status"] != "ok"]
    if not bad:
        return None
    return table(bad, [("bench", "bench", "{}"), ("config", "name", "{}"), ("status", "status", "{}"),
                       ("reason", lambda r: str(r["reason"])[:140], "{}")], title="Skipped / failed")


def check_sections(what: str, sections, allowed, listed=None) -> None:
    """UsageError naming the first of ``sections`` not in ``allowed`` and the sections there are
    (``listed``, default ``allowed``): before any section runs."""
    for name in sections or ():
        if name not in allowed:
            raise UsageError(f"unknown {what} section {name!r}; sections: {', '.join(listed or allowed)}")
