"""Matplotlib figures of ``mane bench all``: one function per seed figure, each drawing mane's
measurements and, where the seed published numbers, those numbers (``seed_figures``) as markers
labelled with the seed's hardware ("read by eye" where the digest read them from a chart).

    from mane.bench import plots
    plots.vulkan_guides(results, "out/plots/vulkan_guides.png")
    written = plots.write_all(results, fits, "out/plots")      # {name: path}

``results`` maps a benchmark target to its JSON (``{"sim": ..., "render": ..., "oit": ...}``);
a missing target or configuration gives a figure that says so rather than no file. Figures are
drawn on matplotlib's Agg canvas directly (no pyplot, no global backend switch).
"""
from __future__ import annotations

from pathlib import Path

from . import seed_figures as SF
from .scaling import render_ms

SEED_STYLE = dict(marker="*", markersize=11, linestyle="--", linewidth=1.0, color="black", alpha=0.8)
SEED_COLOURS = ("black", "dimgray", "saddlebrown", "darkred", "darkgreen", "navy")


# --------------------------------------------------------------------------- helpers
def _figure(ncols: int = 1, nrows: int = 1, size=(7.5, 4.8)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size[0] * ncols, size[1] * nrows), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, [a for row in axes for a in row]


def _meta(results: dict, target: str) -> dict:
    return (results.get(target) or {}).get("meta") or {}


def ours_label(results: dict, target: str) -> str:
    """"mane (GPU, driver, mode, timing)" for a target's run."""
    m = _meta(results, target)
    if not m:
        return f"mane ({target} not run)"
    timing = m.get("timing") or {}
    src = (timing.get("frame_source") or timing.get("step_source") or timing.get("frame") or "?")
    return f"mane: {m.get('renderer', '?')}, {m.get('driver') or '?'}, {m.get('mode')} mode, timing {src}"


def _footer(fig, results: dict, targets, seeds=()) -> None:
    lines = [ours_label(results, t) for t in targets]
    for f in seeds:
        lines.append(f"published: {f.title.split(':')[0]} ({f.seed.split()[-1]}) on {f.hardware}"
                     + (" (values read by eye from the chart)" if any(p.approx for p in f.points) else ""))
        if f.omitted:
            lines.append("  left out: " + "; ".join(f.omitted))
    fig.text(0.01, 0.005, "\n".join(dict.fromkeys(lines)), fontsize=7, va="bottom", ha="left", color="dimgray")
    fig.subplots_adjust(bottom=0.12 + 0.028 * len(lines), top=0.82, wspace=0.3, hspace=0.45)


def _save(fig, path) -> str:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from ..io.atomic import atomic_write_path

    with atomic_write_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format=path.suffix.lstrip(".") or "png")
    return str(path)


def _legend(ax, **kw) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


def _no_data(ax, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", fontsize=9, wrap=True, transform=ax.transAxes,
            color="firebrick")


def _ok(results: dict, target: str, bench: str) -> list[dict]:
    rows = (results.get(target) or {}).get("results") or []
    return [r for r in rows if r.get("bench") == bench and r.get("status") == "ok"]


def _mean(v):
    return v.get("mean") if isinstance(v, dict) else v


def _fps(row: dict):
    """Frames per second of a render row: the pipelined rate (what an application sees)."""
    return row.get("fps") if row.get("fps") else (1e3 / row["pipelined_ms"] if row.get("pipelined_ms") else None)


def _seed_line(ax, fig_data: SF.Figure, series: str, colour="black", x_map=None, label=None) -> None:
    pts = [p for p in fig_data.points if p.series == series]
    if not pts:
        return
    xs = [x_map(p.x) if x_map else p.x for p in pts]
    ax.plot(xs, [p.y for p in pts], **{**SEED_STYLE, "color": colour}, label=label or fig_data.label(series))


def _log_if_wide(ax, values, axis="y") -> None:
    vs = [v for v in values if v is not None and v > 0]
    if vs and max(vs) / min(vs) > 30:
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")


def _bars(ax, categories, series: dict, hatched=()) -> None:
    """Grouped bars: series name -> list of values per category (None: no bar)."""
    n = max(len(series), 1)
    width = 0.8 / n
    greys = ("white", "lightgray", "darkgray", "gray", "whitesmoke", "silver")
    hatches = ("//", "\\\\", "xx", "..", "--", "++")
    k = 0
    for i, (name, values) in enumerate(series.items()):
        xs = [c + (i - (n - 1) / 2) * width for c in range(len(categories))]
        ys = [v if v is not None else 0.0 for v in values]
        kw = {}
        if name in hatched:
            kw = dict(hatch=hatches[k % len(hatches)], edgecolor="black", facecolor=greys[k % len(greys)])
            k += 1
        ax.bar(xs, ys, width=width * 0.95, label=name, **kw)
    ax.set_xticks(range(len(categories)))
    ax.set_xticklabels(categories, fontsize=8, rotation=15)


# --------------------------------------------------------------------------- Woodhouse
def woodhouse_tables(results: dict, path) -> str:
    """Woodhouse Tables 5.1 / 5.2: simulation components (his workload, 25^3 grid), draw ms with and
    without 4x MSAA, and the full-head workload (sim step, render frame)."""
    fig, (a, b, c) = _figure(3, 1, size=(6.0, 5.0))
    t52 = SF.WOODHOUSE_T52
    cats = ["strand dynamics", "clear voxels", "voxel calculations"]
    series = {}
    for r in _ok(results, "sim", "woodhouse"):
        cm = r.get("categories_ms") or {}
        series[f"mane {r['name']}"] = [cm.get("strand_dynamics"), cm.get("clear_voxels"),
                                       cm.get("voxel_calculations")]
    seeds = {s: [next((p.y for p in pts if p.x == cat), None) for cat in cats] for s, pts in t52.series().items()}
    _bars(a, cats, {**series, **{f"Woodhouse {k}": v for k, v in seeds.items()}},
          hatched={f"Woodhouse {k}" for k in seeds})
    a.set_yscale("log")
    a.set_ylabel("ms")
    a.set_title("Table 5.2: simulation components\n(242 strands x 8 / 16, 25^3 voxels)", fontsize=9)
    if not series:
        _no_data(a, "no sim woodhouse rows")
    _legend(a, fontsize=6)

    cats = ["msaa 4", "msaa 1"]
    series = {}
    for r in _ok(results, "render", "woodhouse_msaa"):
        key = f"mane {r.get('shadows')} ({r.get('version')})"
        series.setdefault(key, [None, None])[0 if r.get("msaa") == 4 else 1] = render_ms(r)
    seeds = {s: [next((p.y for p in pts if p.x == f"draw {cat}"), None) for cat in cats]
             for s, pts in t52.series().items()}
    _bars(b, cats, {**series, **{f"Woodhouse {k}": v for k, v in seeds.items()}},
          hatched={f"Woodhouse {k}" for k in seeds})
    b.set_yscale("log")
    b.set_ylabel("ms (render frame)")
    b.set_title("Tables 5.1/5.2: draw with / without 4x MSAA\n(his gpu = DOM, optimised_gpu = density)", fontsize=9)
    if not series:
        _no_data(b, "no render woodhouse_msaa rows")
    _legend(b, fontsize=6)

    names, values = [], []
    for r in _ok(results, "sim", "full_solver"):
        if r.get("grid_method") == "atomic" and not r["name"].endswith("separate"):
            names.append(f"sim step\n{r['name']}")
            values.append(_mean(r.get("step_ms")))
    for r in _ok(results, "render", "target"):
        names.append(f"render frame\n{r.get('rendered_strands')} strands msaa {r.get('msaa')}")
        values.append(render_ms(r))
    if names:
        c.bar(range(len(names)), values, color="tab:blue")
        c.set_xticks(range(len(names)))
        c.set_xticklabels(names, fontsize=7)
        _log_if_wide(c, values)
    else:
        _no_data(c, "no full-head rows")
    c.set_ylabel("ms")
    c.set_title("Full-head workload (no published counterpart)", fontsize=9)
    fig.suptitle("Woodhouse (2017) Tables 5.1 and 5.2", fontsize=11)
    _footer(fig, results, ("sim", "render"), (t52,))
    return _save(fig, path)


# --------------------------------------------------------------------------- Chen
def chen_table2(results: dict, path) -> str:
    """Chen Table 2: FPS against the FLIP grid size, GPU and CPU (NumPy, same method), and the speed-up."""
    fig, (a, b) = _figure(2, 1)
    flip = _ok(results, "sim", "flip")
    shares = _ok(results, "sim", "chen_shares")
    wl = sorted({(r["strands"], r["vertices"]) for r in flip})
    for S, N in wl:
        rows = sorted((r for r in flip if (r["strands"], r["vertices"]) == (S, N)), key=lambda r: r["resolution"])
        xs = [r["resolution"] for r in rows]
        a.plot(xs, [1e3 / _mean(r["apply_ms"]) if _mean(r.get("apply_ms")) else None for r in rows], "o-",
               label=f"mane GPU, volume pass alone ({S}x{N})")
        cpu = [(r["resolution"], 1e3 / r["cpu_ms"]["median"]) for r in rows if (r.get("cpu_ms") or {}).get("median")]
        if cpu:
            a.plot(*zip(*cpu), "s-", label=f"mane NumPy CPU, volume pass alone ({S}x{N})")
        sp = [(r["resolution"], r["speedup"]) for r in rows if r.get("speedup")]
        if sp:
            b.plot(*zip(*sp), "o-", label=f"mane GPU / NumPy, volume pass ({S}x{N})")
    if shares:
        rows = sorted(shares, key=lambda r: r["resolution"])
        a.plot([r["resolution"] for r in rows], [r.get("fps") for r in rows], "^-",
               label="mane GPU, whole simulation step with volume")
    for i, s in enumerate(("CPU", "GPU")):
        _seed_line(a, SF.CHEN_T2, s, SEED_COLOURS[i])
    _seed_line(b, SF.CHEN_T2_SPEEDUP, "speed-up")
    for ax in (a, b):
        ax.set_xscale("log", base=2)
        ax.set_xticks([16, 32, 64])
        ax.set_xticklabels(["16^3", "32^3", "64^3"])
        ax.set_xlabel("grid")
        _legend(ax, fontsize=6)
    a.set_yscale("log")
    a.set_ylabel("frames (applies) per second")
    b.set_ylabel("GPU speed-up over CPU (x)")
    a.set_title("FPS vs grid size", fontsize=9)
    b.set_title("speed-up", fontsize=9)
    if not flip:
        _no_data(a, "no sim flip rows")
    fig.suptitle("Chen (2011) Table 2: FLIP volume, GPU vs CPU", fontsize=11)
    _footer(fig, results, ("sim",), (SF.CHEN_T2,))
    return _save(fig, path)


CHEN_CATS = ("solving_constraints", "volume_method", "force_velocity_position")


def chen_table4(results: dict, path) -> str:
    """Chen Table 4: share of a simulation step, constraints / volume / force-velocity-position."""
    fig, (ax,) = _figure(1, 1, size=(8.5, 4.8))
    labels, shares, hatched = [], [], []
    for s, pts in SF.CHEN_T4.series().items():
        labels.append(f"Chen {s} (32^3)\n{SF.CHEN_T4.hardware.split(' (')[0] if s == 'GPU' else 'i7-930'}")
        shares.append([next((p.y for p in pts if p.x == c), 0.0) for c in CHEN_CATS])
        hatched.append(True)
    rows = sorted(_ok(results, "sim", "chen_shares"), key=lambda r: r["resolution"])
    for r in rows:
        labels.append(f"mane GPU {r['name']}")
        shares.append([100.0 * ((r.get("share") or {}).get(c) or 0.0) for c in CHEN_CATS])
        hatched.append(False)
    left = [0.0] * len(labels)
    colours = ("tab:orange", "tab:blue", "tab:green")
    for j, cat in enumerate(CHEN_CATS):
        vals = [s[j] for s in shares]
        for i, v in enumerate(vals):
            ax.barh(i, v, left=left[i], color=colours[j], hatch="//" if hatched[i] else None, edgecolor="black",
                    label=cat.replace("_", " ") if i == 0 else None)
            if v >= 4:
                ax.text(left[i] + v / 2, i, f"{v:.1f}%", ha="center", va="center", fontsize=7)
            left[i] += v
    ax.set_yticks(range(len(labels)))
    ax.set_yticklabels(labels, fontsize=7)
    ax.set_xlim(0, 100)
    ax.set_xlabel("% of a simulation step")
    _legend(ax, fontsize=7, loc="lower right")
    if not rows:
        _no_data(ax, "no sim chen_shares rows")
    fig.suptitle("Chen (2011) Table 4: share of each stage (hatched: published)", fontsize=11)
    fig.subplots_adjust(left=0.25)
    _footer(fig, results, ("sim",), (SF.CHEN_T4,))
    return _save(fig, path)


def chen_table5(results: dict, path) -> str:
    """Chen Table 5: FPS against viewing distance at his resolutions, LOD on and off."""
    fig, (ax,) = _figure(1, 1, size=(8.5, 5.2))
    rows = _ok(results, "render", "chen_lod")
    groups: dict = {}
    for r in rows:
        groups.setdefault((r.get("resolution"), r.get("lod")), []).append(r)
    for (res, lod), rs in sorted(groups.items(), key=lambda kv: (str(kv[0][0]), str(kv[0][1]))):
        rs.sort(key=lambda r: r["distance"])
        ax.plot([r["distance"] for r in rs], [_fps(r) for r in rs], "o-" if lod == "on" else "o:",
                label=f"mane {res} LOD {lod}")
    for i, s in enumerate(SF.CHEN_T5.series()):
        _seed_line(ax, SF.CHEN_T5, s, SEED_COLOURS[i % len(SEED_COLOURS)], label=f"Chen {s} (LOD)")
    ax.set_xlabel("viewing distance (mane: x the framing distance; Chen: units not given)")
    ax.set_ylabel("FPS")
    ax.set_yscale("log")
    _legend(ax, fontsize=6, ncol=2)
    if not rows:
        _no_data(ax, "no render chen_lod rows")
    fig.suptitle("Chen (2011) Table 5: FPS vs viewing distance with LOD", fontsize=11)
    _footer(fig, results, ("render",), (SF.CHEN_T5,))
    return _save(fig, path)


# --------------------------------------------------------------------------- Hunz
def hunz_fig33(results: dict, path) -> str:
    """Hunz Fig. 33: ms against strand count for each shading model (no published values)."""
    fig, (ax,) = _figure(1, 1)
    rows = _ok(results, "render", "hunz_shading")
    by_model: dict = {}
    for r in rows:
        by_model.setdefault(r.get("shading"), []).append(r)
    for model, rs in by_model.items():
        rs.sort(key=lambda r: r["rendered_strands"])
        ax.plot([r["rendered_strands"] for r in rs], [render_ms(r) for r in rs], "o-", label=f"mane {model}")
    ax.text(0.02, 0.97, "Hunz Fig. 33 (GTX 960): no values published outside the chart;\n"
            "the thesis says the models 'all perform very similarly'", transform=ax.transAxes, fontsize=7,
            va="top", color="dimgray")
    ax.set_xlabel("rendered strands")
    ax.set_ylabel("ms per frame")
    _legend(ax, fontsize=7, loc="lower right")
    if not rows:
        _no_data(ax, "no render hunz_shading rows")
    fig.suptitle("Hunz (2016) Fig. 33: strands x shading model (one light, no shadows, GL_LINES)", fontsize=11)
    _footer(fig, results, ("render",), ())
    return _save(fig, path)


def hunz_fig36(results: dict, path) -> str:
    """Hunz Fig. 36: ms against shadow map size, per shadow method and PCF."""
    fig, (ax,) = _figure(1, 1, size=(9.0, 5.5))
    rows = _ok(results, "render", "hunz_shadows")
    groups: dict = {}
    none = [r for r in rows if r.get("shadows") == "none"]
    for r in rows:
        if r.get("shadow_map_size"):
            groups.setdefault((r["shadows"], r.get("pcf")), []).append(r)
    for (method, pcf), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1] or 0)):
        rs.sort(key=lambda r: r["shadow_map_size"])
        ax.plot([r["shadow_map_size"] for r in rs], [render_ms(r) for r in rs], "o-" if pcf in (1, None) else "x--",
                label=f"mane {method} pcf {pcf}x{pcf}")
    if none:
        ax.axhline(render_ms(none[0]), color="gray", linestyle=":", label="mane no shadows")
    for i, s in enumerate(SF.HUNZ_F36.series()):
        _seed_line(ax, SF.HUNZ_F36, s, SEED_COLOURS[i], label=f"Hunz {s} (GTX 960, from the text, ~)")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("shadow map size (texels per side)")
    ax.set_ylabel("ms per frame")
    _legend(ax, fontsize=6, ncol=3)
    if not rows:
        _no_data(ax, "no render hunz_shadows rows")
    fig.suptitle("Hunz (2016) Fig. 36: shadow method x map size x PCF", fontsize=11)
    _footer(fig, results, ("render",), (SF.HUNZ_F36,))
    return _save(fig, path)


def _oit_rows(results: dict) -> list[dict]:
    return [r for r in (results.get("oit") or {}).get("methods") or [] if r.get("status") == "ok"]


def hunz_fig41(results: dict, path) -> str:
    """Hunz Fig. 41: ms per OIT method x shadow method (his viewport where measured, straight groom)."""
    fig, (ax,) = _figure(1, 1, size=(10.0, 5.5))
    rows = _oit_rows(results)
    sizes = [tuple(r["size"]) for r in rows]
    size = (656, 861) if (656, 861) in sizes else (sizes[0] if sizes else None)
    rows = [r for r in rows if tuple(r["size"]) == size and r.get("groom") == "straight"]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    shadows = list(dict.fromkeys(r["shadows"] for r in rows))
    series = {f"mane {s}": [next((_mean(r["frame_ms"]) for r in rows if r["method"] == m and r["shadows"] == s),
                                 None) for m in methods] for s in shadows}
    if methods:
        _bars(ax, methods, series)
        n = max(len(series), 1)
        for i, s in enumerate(SF.HUNZ_F41.series()):
            pts = SF.HUNZ_F41.series()[s]
            xs, ys = [], []
            for p in pts:
                if p.x in methods:
                    j = methods.index(p.x)
                    k = shadows.index(s) if s in shadows else (n - 1) / 2
                    xs.append(j + (k - (n - 1) / 2) * 0.8 / n)
                    ys.append(p.y)
            if xs:
                ax.plot(xs, ys, linestyle="none", marker="*", markersize=13, color=SEED_COLOURS[i],
                        label=f"Hunz {s} (GTX 960, 656x861; ms from published FPS)")
        _log_if_wide(ax, [v for vs in series.values() for v in vs] + [p.y for p in SF.HUNZ_F41.points])
    else:
        _no_data(ax, "no oit method rows")
    ax.set_ylabel("ms per frame")
    _legend(ax, fontsize=6, ncol=2)
    fig.suptitle(f"Hunz (2016) Fig. 41: OIT method x shadow method (mane at "
                 f"{size[0]}x{size[1]})" if size else "Hunz (2016) Fig. 41", fontsize=11)
    _footer(fig, results, ("oit",), (SF.HUNZ_F41,))
    return _save(fig, path)


def hunz_fig42(results: dict, path) -> str:
    """Hunz Fig. 42: memory per OIT method (MiB), mane at each measured viewport and Hunz's."""
    fig, (ax,) = _figure(1, 1, size=(10.0, 5.5))
    mem = (results.get("oit") or {}).get("memory") or []
    seed = SF.HUNZ_F42
    methods = list(dict.fromkeys([r["method"] for r in mem] + [p.x for p in seed.points]))
    series = {}
    for r in mem:
        key = f"mane {r['size'][0]}x{r['size'][1]}"
        series.setdefault(key, [None] * len(methods))[methods.index(r["method"])] = r.get("oit_mib")
    for s, pts in seed.series().items():
        vals = [None] * len(methods)
        for p in pts:
            vals[methods.index(p.x)] = p.y
        series[f"Hunz {s}"] = vals
    _bars(ax, methods, series, hatched={k for k in series if k.startswith("Hunz")})
    _log_if_wide(ax, [v for vs in series.values() for v in vs])
    ax.set_ylabel("MiB")
    _legend(ax, fontsize=7)
    if not mem:
        _no_data(ax, "no oit memory rows")
    fig.suptitle("Hunz (2016) Fig. 42: OIT memory (hatched: published; TressFX 656x861 '~276 MB' in his text)",
                 fontsize=10)
    _footer(fig, results, ("oit",), (seed,))
    return _save(fig, path)


# --------------------------------------------------------------------------- Vulkan
def _vulkan(results: dict, path, bench: str, seed: SF.Figure, xlabel: str, x_of=None) -> str:
    fig, (ax,) = _figure(1, 1)
    rows = sorted(_ok(results, "render", bench), key=lambda r: r.get("parameter") or 0)
    x_of = x_of or (lambda r: r.get("parameter"))
    if rows:
        ax.plot([x_of(r) for r in rows], [_fps(r) for r in rows], "o-", label="mane FPS (pipelined frames)")
        gf = [(x_of(r), r.get("gpu_fps")) for r in rows if r.get("gpu_fps")]
        if gf:
            ax.plot(*zip(*gf), "s:", label="mane 1000 / frame ms (GPU timer where available)")
    else:
        _no_data(ax, f"no render {bench} rows")
    _seed_line(ax, seed, "fps")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("FPS")
    _log_if_wide(ax, [_fps(r) for r in rows] + [p.y for p in seed.points])
    _legend(ax, fontsize=7)
    fig.suptitle(f"{seed.title}", fontsize=11)
    _footer(fig, results, ("render",), (seed,))
    return _save(fig, path)


def vulkan_guides(results: dict, path) -> str:
    return _vulkan(results, path, "vulkan_guides", SF.VULKAN_GUIDES, "guide strands")


def vulkan_divisions(results: dict, path) -> str:
    return _vulkan(results, path, "vulkan_divisions", SF.VULKAN_DIVISIONS, "tessellation divisions per strand")


def vulkan_strands_per_guide(results: dict, path) -> str:
    return _vulkan(results, path, "vulkan_strands_per_guide", SF.VULKAN_SPG, "rendered strands per guide")


def vulkan_pcf(results: dict, path) -> str:
    return _vulkan(results, path, "vulkan_pcf", SF.VULKAN_PCF, "shadow-map samples (PCF taps) per pixel")


# --------------------------------------------------------------------------- scaling
SCALING_PANELS = (("strands", "strands / particles"), ("segments", "segments"),
                  ("pixels", "pixels / shadow-map texels"), ("grid", "grid cells"))


def scaling(results: dict, fits: list[dict], path) -> str:
    """Log-log time against strands, segments, pixels and grid cells, with the power-law fits."""
    import numpy as np

    fig, axes = _figure(2, 2, size=(6.5, 4.6))
    panel_of = {"strands": 0, "particles": 0, "segments": 1, "pixels": 2, "shadow map texels": 2, "grid": 3}
    for i, (_, title) in enumerate(SCALING_PANELS):
        axes[i].set_title(f"time vs {title}", fontsize=9)
        axes[i].set_xscale("log")
        axes[i].set_yscale("log")
        axes[i].set_ylabel("ms")
    count = [0] * 4
    for f in fits:
        i = panel_of.get(f["variable"])
        if i is None or count[i] >= 10:      # keep the legends readable; all fits are in the CSV
            continue
        count[i] += 1
        ax = axes[i]
        xs = np.array(f["x"], float)
        line = ax.plot(xs, f["y"], "o", markersize=3)[0]
        xx = np.geomspace(xs.min(), xs.max(), 20)
        ax.plot(xx, f["coefficient"] * xx ** f["exponent"], "-", color=line.get_color(), linewidth=1,
                label=f"{f['target']} {f['series']} [{f['group']}]: k={f['exponent']:.2f}, R²={f['r2']:.2f}, n={f['n']}")
    for i, ax in enumerate(axes):
        if count[i]:
            _legend(ax, fontsize=5)
        else:
            _no_data(ax, "no series to fit")
    fig.suptitle("How time scales: t = c x^k (least squares on logs)", fontsize=11)
    _footer(fig, results, ("sim", "render", "oit"), ())
    return _save(fig, path)


# --------------------------------------------------------------------------- all of them
PLOTS = {
    "woodhouse_tables": woodhouse_tables,
    "chen_table2_flip": chen_table2,
    "chen_table4_shares": chen_table4,
    "chen_table5_lod": chen_table5,
    "hunz_fig33_shading": hunz_fig33,
    "hunz_fig36_shadows": hunz_fig36,
    "hunz_fig41_oit": hunz_fig41,
    "hunz_fig42_memory": hunz_fig42,
    "vulkan_guides": vulkan_guides,
    "vulkan_divisions": vulkan_divisions,
    "vulkan_strands_per_guide": vulkan_strands_per_guide,
    "vulkan_pcf": vulkan_pcf,
}
ALL_PLOTS = tuple(PLOTS) + ("scaling",)


def write_all(results: dict, fits: list[dict], out_dir, progress=None) -> dict:
    """Every plot as out_dir/<name>.png: {name: path or "error: ..."}. A plot that fails is
    replaced by a figure with the error, so every promised file exists."""
    out_dir = Path(out_dir)
    written = {}
    jobs = [(name, (lambda fn: lambda p: fn(results, p))(fn)) for name, fn in PLOTS.items()]
    jobs.append(("scaling", lambda p: scaling(results, fits, p)))
    for name, job in jobs:
        path = out_dir / f"{name}.png"
        try:
            written[name] = job(path)
        except Exception as exc:  # a broken plot must not lose the others
            fig, (ax,) = _figure(1, 1)
            _no_data(ax, f"{name}: {type(exc).__name__}: {exc}"[:300])
            _save(fig, path)
            written[name] = f"error: {type(exc).__name__}: {exc}"
        if progress is not None:
            progress(name)
    return written


__all__ = ["write_all", "PLOTS", "ALL_PLOTS", "ours_label", "scaling", "woodhouse_tables", "chen_table2",
           "chen_table4", "chen_table5", "hunz_fig33", "hunz_fig36", "hunz_fig41", "hunz_fig42", "vulkan_guides",
           "vulkan_divisions", "vulkan_strands_per_guide", "vulkan_pcf"]
