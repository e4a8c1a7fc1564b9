"""How time scales: power-law fits ``t = c * x^k`` of benchmark times against strands, segments,
pixels and grid size, on a log-log least-squares line (``numpy.polyfit``).

    fit = fit_power_law([1e3, 1e4, 1e5], [0.06, 0.12, 0.38])   # {"exponent", "coefficient", "r2", "n", ...}
    fits = scaling_fits({"sim": sim_result, "render": render_result, "oit": oit_result})

``scaling_fits`` picks, from the results of ``mane bench sim / render / oit``, every series
where one variable changes and the rest of the configuration stays the same, and fits it. An
exponent near 1 means time grows in proportion (a throughput-bound stage), near 0 that the
variable hardly matters (fixed costs dominate: launch overheads, small workloads). A series with
fewer than two positive points is left out; with two points R^2 is 1 by construction (``n`` says
how many points a fit has).
"""
from __future__ import annotations

import math

import numpy as np


def fit_power_law(x, y) -> dict | None:
    """Least-squares line through (log x, log y): exponent k, coefficient c (t = c x^k), R^2.

    Non-positive or non-finite points are dropped; None when fewer than two distinct x remain."""
    pts = [(float(a), float(b)) for a, b in zip(x, y)
           if a is not None and b is not None and math.isfinite(float(a)) and math.isfinite(float(b))
           and float(a) > 0 and float(b) > 0]
    if len({a for a, _ in pts}) < 2:
        return None
    pts.sort()
    lx = np.log(np.array([a for a, _ in pts]))
    ly = np.log(np.array([b for _, b in pts]))
    k, logc = np.polyfit(lx, ly, 1)
    pred = k * lx + logc
    ss_res = float(np.sum((ly - pred) ** 2))
    ss_tot = float(np.sum((ly - ly.mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    return {"exponent": float(k), "coefficient": float(math.exp(logc)), "r2": float(r2), "n": len(pts),
            "x": [a for a, _ in pts], "y": [b for _, b in pts]}


def _mean(v):
    if isinstance(v, dict):
        return v.get("mean")
    return v


def render_ms(row: dict):
    """A render row's GPU time: the gapless ``gpu_ms`` where measured, else ``frame_ms``."""
    g = _mean(row.get("gpu_ms"))
    return g if g is not None else _mean(row.get("frame_ms"))


def _ok(rows, bench):
    return [r for r in rows or [] if r.get("bench") == bench and r.get("status") == "ok"]


def _group(rows, key, x, y):
    """{group key: ([x], [y])} over rows."""
    out: dict = {}
    for r in rows:
        try:
            k, xv, yv = key(r), x(r), y(r)
        except (KeyError, TypeError, ValueError):
            continue
        if xv is None or yv is None:
            continue
        xs, ys = out.setdefault(k, ([], []))
        xs.append(xv)
        ys.append(yv)
    return out


def _add(fits, variable, target, series, what, groups, unit_x):
    for g, (xs, ys) in groups.items():
        f = fit_power_law(xs, ys)
        if f is None:
            continue
        fits.append({"variable": variable, "target": target, "series": series, "group": str(g),
                     "time": what, "x_unit": unit_x, **f})


def scaling_fits(results: dict) -> list[dict]:
    """Power-law fits over the results of the sim / render / oit benchmarks (any may be missing)."""
    fits: list[dict] = []
    sim = (results.get("sim") or {}).get("results") or []
    render = (results.get("render") or {}).get("results") or []
    oit = (results.get("oit") or {}).get("methods") or []

    # ---- simulation
    core = _ok(sim, "dftl_core")
    _add(fits, "strands", "sim", "dftl_core", "step_ms.mean",
         _group(core, lambda r: f"{r['vertices']} vertices", lambda r: r["strands"],
                lambda r: _mean(r["step_ms"])), "strands")
    _add(fits, "segments", "sim", "dftl_core", "step_ms.mean",
         _group(core, lambda r: f"{r['strands']} strands", lambda r: r["vertices"] - 1,
                lambda r: _mean(r["step_ms"])), "segments per strand")
    _add(fits, "particles", "sim", "dftl_core", "kernel_sum_ms",
         _group(core, lambda r: "all", lambda r: r["particles"], lambda r: r.get("kernel_sum_ms")), "particles")
    _add(fits, "grid", "sim", "grid_friction", "total ms",
         _group(_ok(sim, "grid_friction"), lambda r: r.get("variant") or r.get("method"),
                lambda r: r["resolution"] ** 3, lambda r: r.get("total")), "grid cells")
    flip = _ok(sim, "flip")
    _add(fits, "grid", "sim", "flip (GPU)", "apply_ms.mean",
         _group(flip, lambda r: f"{r['strands']}x{r['vertices']}", lambda r: r["resolution"] ** 3,
                lambda r: _mean(r["apply_ms"])), "grid cells")
    _add(fits, "grid", "sim", "flip (NumPy CPU)", "cpu_ms.median",
         _group(flip, lambda r: f"{r['strands']}x{r['vertices']}", lambda r: r["resolution"] ** 3,
                lambda r: (r.get("cpu_ms") or {}).get("median")), "grid cells")

    # ---- rendering
    _add(fits, "strands", "render", "hunz_shading", "gpu/frame ms",
         _group(_ok(render, "hunz_shading"), lambda r: r.get("shading"), lambda r: r["rendered_strands"],
                render_ms), "rendered strands")
    _add(fits, "strands", "render", "vulkan_guides", "gpu/frame ms",
         _group(_ok(render, "vulkan_guides"), lambda r: "guides x spg", lambda r: r["rendered_strands"],
                render_ms), "rendered strands")
    _add(fits, "strands", "render", "vulkan_strands_per_guide", "gpu/frame ms",
         _group(_ok(render, "vulkan_strands_per_guide"), lambda r: "strands per guide",
                lambda r: r["rendered_strands"], render_ms), "rendered strands")
    _add(fits, "segments", "render", "vulkan_divisions", "gpu/frame ms",
         _group(_ok(render, "vulkan_divisions"), lambda r: "divisions",
                lambda r: r.get("rendered_segments") or r.get("parameter"), render_ms), "rendered segments")
    _add(fits, "shadow map texels", "render", "hunz_shadows", "gpu/frame ms",
         _group([r for r in _ok(render, "hunz_shadows") if r.get("shadow_map_size")],
                lambda r: f"{r['shadows']} pcf {r.get('pcf')}", lambda r: r["shadow_map_size"] ** 2,
                render_ms), "texels")
    chen = [r for r in _ok(render, "chen_lod") if r.get("lod") == "off"]
    _add(fits, "pixels", "render", "chen_lod (LOD off)", "gpu/frame ms",
         _group(chen, lambda r: f"distance {r.get('distance')}", lambda r: r["size"][0] * r["size"][1],
                render_ms), "pixels")
    # ---- transparency
    oit_ok = [r for r in oit if r.get("status") == "ok"]
    _add(fits, "pixels", "oit", "methods", "frame_ms.mean",
         _group(oit_ok, lambda r: f"{r['method']} {r.get('rasterizer', 'hardware')} {r['shadows']} {r['groom']}",
                lambda r: r["size"][0] * r["size"][1],
                lambda r: _mean(r.get("frame_ms"))), "pixels")
    return fits


def summarise(fits: list[dict]) -> list[dict]:
    """One line per (variable, target, series): the median exponent over its groups, the range and
    the lowest R^2."""
    out = {}
    for f in fits:
        out.setdefault((f["variable"], f["target"], f["series"]), []).append(f)
    rows = []
    for (var, target, series), fs in out.items():
        ks = sorted(f["exponent"] for f in fs)
        rows.append({"variable": var, "target": target, "series": series, "groups": len(fs),
                     "exponent_median": float(np.median(ks)), "exponent_min": ks[0], "exponent_max": ks[-1],
                     "r2_min": min(f["r2"] for f in fs), "points": max(f["n"] for f in fs),
                     "x_unit": fs[0]["x_unit"], "time": fs[0]["time"]})
    return rows


__all__ = ["fit_power_law", "scaling_fits", "summarise", "render_ms"]
