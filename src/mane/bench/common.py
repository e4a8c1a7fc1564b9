"""Shared benchmark pieces: the JSON envelope (``meta``), timing statistics, tables.

    meta = envelope(ctx, target="sim", mode="quick", settings={...}, timing={...})
    stats(samples_ms)        # {"mean": .., "median": .., "p95": .., "min": .., "max": .., "n": ..}
    print(table(rows, [("strands", "{:d}"), ("step ms", "{:.3f}")]))
"""
from __future__ import annotations

import datetime as _dt
import math
import os
import platform
import sys

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


def _versions() -> dict:
    out = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "moderngl"):
        try:
            mod = __import__(name)
            out[name] = str(getattr(mod, "__version__", "?"))
        except Exception:
            out[name] = None
    return out


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
                 "argv": list(sys.argv)},
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
