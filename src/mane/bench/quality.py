"""``mane bench quality --out DIR``: the validation figures, gathered from the harnesses that exist.

    result = run(ctx, "quick", image_dir="out/quality")     # JSON object; images written there

Sections (each ``{"status": "ok" | "skipped" | "error", "reason", ...}``):

``shading``
    every shading model's GLSL (``mane.render.shading.evaluate_glsl``, the compute harness) against
    its NumPy twin written from the published equations (``mane.twins.shading``), on random unit
    directions and on a (theta_o, phi) sweep; ``marschner_lut`` against the analytic GLSL Marschner
    (the LUT builder is ``shading/luts.py``). Max and 99th-percentile relative error with the tests' floor
    (1e-3 of the batch peak). Image: GLSL | NumPy | |difference| per model over the sweep.
``shadows``
    every shadow method's light-0 visibility (``mane.render.shadow_probe``) against the exact
    transmittance of a ray cast through the drawn segments (``src/mane/twins/shadow.py``)
    on a curtain of wavy strands lit from the side: mean / max absolute error, bias, and the
    no-shadow baseline. Image: a slice through the curtain, exact | each method | error.
``oit``
    every OIT method's image against the exact sort (every fragment from an unbounded A-buffer,
    sorted and blended in float64, ``src/mane/twins/oit.py``): mean / max / p99 absolute
    difference (of 255) and pixels off by more than 1/255. Image: reference | method | 4x difference.
``simulation``
    invariants over a short run of the solver on a scalp of strands with the head nodding (package
    code only: ``Simulator.max_length_error`` / ``max_root_error`` / ``max_penetration`` /
    ``kinetic_energy`` / ``nan_recoveries``), and a hanging chain settling (energy decays).
    Image: the invariants against time.

The references are the NumPy twins in ``mane.twins`` (the tests' golden values too); nothing of
them is reimplemented here.
"""
from __future__ import annotations

import math
import sys
import time
import traceback
from pathlib import Path

import numpy as np

from .common import Skip, envelope, fmt, sanitise, table, title_line, to_json, write_result

MODE_CONFIG = {
    "quick": dict(shading_random=1024, sweep=(48, 96), shadow_slice=(40, 100), shadow_near=600,
                  shadow_map_size=256, oit_size=(96, 72), sim_strands=64, sim_points=16, sim_steps=60,
                  chain_steps=240),
    "default": dict(shading_random=4096, sweep=(90, 180), shadow_slice=(60, 160), shadow_near=1500,
                    shadow_map_size=512, oit_size=(120, 90), sim_strands=256, sim_points=16, sim_steps=120,
                    chain_steps=300),
    "full": dict(shading_random=16384, sweep=(128, 256), shadow_slice=(80, 220), shadow_near=3000,
                 shadow_map_size=1024, oit_size=(240, 180), sim_strands=1000, sim_points=32, sim_steps=240,
                 chain_steps=300),
}


def relative_error(got, ref, floor: float = 1e-3) -> np.ndarray:
    """|got - ref| / max(|ref|, floor * max|ref|) elementwise (the shading tests' measure)."""
    got = np.asarray(got, np.float64)
    ref = np.asarray(ref, np.float64)
    peak = float(np.abs(ref).max()) if ref.size else 0.0
    scale = np.maximum(np.abs(ref), floor * peak if peak > 0 else 1e-30)
    return np.abs(got - ref) / scale


# --------------------------------------------------------------------------- figures
def _figure(ncols, nrows, size=(2.6, 2.4)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size[0] * ncols, size[1] * nrows + 0.6), dpi=100)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def _save(fig, path) -> str:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from ..io.atomic import atomic_write_path

    with atomic_write_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format=path.suffix.lstrip(".") or "png")
    return str(path)


def _imshow(ax, img, title, **kw):
    ax.imshow(img, **kw)
    ax.set_title(title, fontsize=7)
    ax.set_xticks([])
    ax.set_yticks([])


def _note_figure(path, text: str) -> str:
    fig, axes = _figure(1, 1, size=(6, 2))
    axes[0][0].axis("off")
    axes[0][0].text(0.5, 0.5, text, ha="center", va="center", wrap=True, fontsize=9, color="firebrick")
    return _save(fig, path)


# --------------------------------------------------------------------------- shading
def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def _sweep_dirs(n_theta: int, n_phi: int, theta_i_deg: float = 30.0):
    """T = +x; L at theta_i in the x-y plane; V over theta_o in [-80, 80] deg x phi in [-180, 180]."""
    T = np.array([1.0, 0.0, 0.0])
    ti = math.radians(theta_i_deg)
    L = np.array([math.sin(ti), math.cos(ti), 0.0])
    to = np.radians(np.linspace(-80, 80, n_theta))[:, None]
    ph = np.radians(np.linspace(-180, 180, n_phi))[None, :]
    V = np.stack([np.sin(to) * np.ones_like(ph), np.cos(to) * np.cos(ph), np.cos(to) * np.sin(ph)], axis=-1)
    V = V.reshape(-1, 3)
    n = len(V)
    return (np.tile(T, (n, 1)).astype(np.float32), V.astype(np.float32), np.tile(L, (n, 1)).astype(np.float32))


def shading(ctx, cfg, image_dir, log) -> dict:
    import dataclasses

    from ..render.shading import MODELS, ShadingSettings, evaluate_glsl

    from ..twins import shading as R
    rng = np.random.default_rng(7)
    n = int(cfg["shading_random"])
    T, V, L, rand = _unit(rng, n), _unit(rng, n), _unit(rng, n), rng.random(n).astype(np.float32)
    ST, SV, SL = _sweep_dirs(*cfg["sweep"])
    rows, maps = [], {}
    for model in MODELS:
        log(f"shading: {model}")
        s = ShadingSettings(model=model, melanin=(1.3, 0.3))
        row = {"model": model, "status": "ok", "reason": None}
        try:
            g = evaluate_glsl(ctx, s, T, V, L, strand_rand=rand)
            gs = evaluate_glsl(ctx, s, ST, SV, SL)
            if hasattr(R, model):
                fn = getattr(R, model)
                ref = fn(T.astype(float), V.astype(float), L.astype(float), R.material(s, rand.astype(float)))
                refs = fn(ST.astype(float), SV.astype(float), SL.astype(float), R.material(s))
                row["against"] = f"NumPy twin mane.twins.shading.{model} (published equations)"
            elif model == "chiang":
                from ..twins import chiang as C
                m = {**R.material(s), "beta_n": s.beta_n}
                ref = C.chiang(T.astype(float), V.astype(float), L.astype(float), m, n_h=512)
                refs = C.chiang(ST.astype(float), SV.astype(float), SL.astype(float), m, n_h=512)
                row["against"] = ("NumPy twin mane.twins.chiang.chiang (Chiang 2016 / pbrt, "
                                  "integrated over h; itself within 1 % of Mitsuba 3's hair BSDF)")
            elif model == "marschner_lut":
                a = dataclasses.replace(s, model="marschner")
                ref = evaluate_glsl(ctx, a, T, V, L, strand_rand=rand)
                refs = evaluate_glsl(ctx, a, ST, SV, SL)
                row["against"] = "analytic Marschner GLSL (the LUT is built by shading/luts.py)"
            else:
                raise Skip(f"no NumPy reference for {model!r}")
            floor = 1e-2 if model in ("marschner_lut", "chiang") else 1e-3    # the tests' floors (tables)
            row.update(_errors([g, gs], [ref, refs], floor))
            lum = np.array([0.2126, 0.7152, 0.0722])
            maps[model] = ((gs @ lum).reshape(cfg["sweep"]), (np.asarray(refs) @ lum).reshape(cfg["sweep"]))
        except Skip as exc:
            row.update(status="skipped", reason=str(exc))
        except Exception as exc:
            row.update(status="error", reason=f"{type(exc).__name__}: {exc}"[:400])
        rows.append(row)
    rows.append(_near_field_row(ctx, T, V, L, rng))
    out = {"status": "ok", "reason": None, "models": rows,
           "measure": "relative error |glsl - ref| / max(|ref|, 1e-3 * peak) over random unit T, V, L and a "
                      "(theta_o in [-80, 80], phi in [-180, 180]) sweep at theta_i = 30 deg; melanin (1.3, 0.3); "
                      "floor 1e-2 of the peak for the LUT model (bilinear 256^2 tables against the analytic model)",
           "tolerance_in_tests": {"analytic models: max relative error": 1e-3,
                                  "marschner_lut: mean |err| / mean": 0.01, "marschner_lut: max |err| / peak": 0.05,
                                  "marschner_lut: p95 relative error": 0.01}}
    if image_dir is not None and maps:
        fig, axes = _figure(3, len(maps), size=(2.8, 1.7))
        for i, (model, (gm, rm)) in enumerate(maps.items()):
            vmax = float(max(gm.max(), rm.max(), 1e-12))
            ext = dict(aspect="auto", extent=(-180, 180, -80, 80), origin="lower", cmap="magma", vmin=0, vmax=vmax)
            _imshow(axes[i][0], gm, f"{model}: GLSL", **ext)
            ref_name = "analytic GLSL" if model == "marschner_lut" else "NumPy"
            _imshow(axes[i][1], rm, f"{model}: {ref_name}", **ext)
            d = np.abs(gm - rm)
            _imshow(axes[i][2], d, f"|diff| (max {d.max() / vmax:.1e} of peak)", **{**ext, "vmax": None,
                                                                                  "cmap": "viridis"})
        fig.suptitle("Shading: luminance over phi (x, deg) and theta_o (y, deg), theta_i = 30 deg", fontsize=9)
        fig.tight_layout()
        out["image"] = _save(fig, Path(image_dir) / "shading.png")
    return out


def _errors(gots, refs, floor: float) -> dict:
    """A shading row's figures: GLSL results ``gots`` against ``refs`` (lists of (N, 3) arrays;
    ``relative_error`` per pair, its floor a fraction ``floor`` of that pair's peak)."""
    rel = np.concatenate([relative_error(g, r, floor).ravel() for g, r in zip(gots, refs)])
    diff = np.abs(np.concatenate([np.ravel(np.asarray(g) - np.asarray(r)) for g, r in zip(gots, refs)]))
    ref = np.abs(np.concatenate([np.ravel(r) for r in refs]))
    got = np.concatenate([np.ravel(g) for g in gots])
    return dict(max_rel_error=float(rel.max()), p95_rel_error=float(np.quantile(rel, 0.95)),
                p99_rel_error=float(np.quantile(rel, 0.99)), rel_error_floor=floor,
                max_abs_over_peak=float(diff.max() / max(ref.max(), 1e-30)),
                mean_abs_over_mean=float(diff.mean() / max(ref.mean(), 1e-30)),
                peak=float(ref.max()), samples=int(sum(len(g) for g in gots)),
                finite=bool(np.isfinite(got).all()), non_negative=bool((got >= 0).all()))


def _near_field_row(ctx, T, V, L, rng) -> dict:
    """Chiang's near field (ShadingSettings.near_field) on the random directions at random
    offsets h: the fibre at h (footprint 0) and its mean over a footprint of 0.5 of h (the
    running integral's table), against the twin's fibre_near and its mean by steps of gamma."""
    from ..render.shading import ShadingSettings, evaluate_glsl
    from ..twins import chiang as C

    row = {"model": "chiang near field", "status": "ok", "reason": None,
           "against": ("NumPy twin mane.twins.chiang.fibre_near at h and its mean over h +- 0.25 (itself "
                       "within 0.5 % of Mitsuba 3's hair eval at each h)")}
    try:
        s = ShadingSettings(model="chiang", melanin=(1.3, 0.3), near_field=True)
        h = rng.uniform(-1.0, 1.0, len(T))
        angles = C.signed_angles(T, V, L)
        kw = dict(roughness=s.roughness, shift=s.shift, beta_n=s.beta_n, eta=s.eta)
        sigma = s.resolved_sigma_a()
        gots = [evaluate_glsl(ctx, s, T, V, L, h=h, footprint=0.0), evaluate_glsl(ctx, s, T, V, L, h=h, footprint=0.5)]
        refs = [C.fibre_near(*angles, h, sigma, **kw), C.near_mean(*angles, h - 0.25, h + 0.25, sigma, steps=64, **kw)]
        row.update(_errors(gots, refs, 1e-2))
    except Exception as exc:
        row.update(status="error", reason=f"{type(exc).__name__}: {exc}"[:400])
    return row


# --------------------------------------------------------------------------- shadows
# The shadow validation's scene (also tests/test_render_shadows.py's): a curtain groom lit from
# the side, drawn with settings under which every opacity method estimates prod(1 - alpha)
# over the strands a point's ray toward the light crosses (strand_opacity = -ln(1 - alpha),
# shadow_density = 1).
SHADOW_ALPHA = 0.3
SHADOW_LIGHT_DIRECTION = (1.0, 0.35, 0.25)


def curtain_groom(nx=10, nz=5, n=12, seed=0):
    """A curtain of wavy strands hanging from a 6 x 3 cm patch (the shadow validation's workload)."""
    from ..groom import Groom

    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n)
    out = []
    for x in np.linspace(-0.03, 0.03, nx):
        for z in np.linspace(-0.015, 0.015, nz):
            ph = rng.uniform(0, 2 * np.pi)
            amp = rng.uniform(0.003, 0.008)
            out.append(np.c_[x + amp * np.sin(ph + 9 * t) + 0.01 * t ** 2, 0.1 - 0.2 * t,
                             z + amp * np.cos(ph + 7 * t)])
    return Groom.from_strands(out)


def shadow_light():
    """The shadow scene's light: directional, from the side (light 0 casts the shadows)."""
    from ..render import Light

    return Light("directional", SHADOW_LIGHT_DIRECTION)


def shadow_settings(shadow_map_size: int = 512) -> dict:
    """The shadow scene's RenderSettings fields (shadows="none"; a method is a change)."""
    return dict(size=(48, 32), msaa=1, strands_per_guide=4, width=0.001, width_tip=1.0,
                shadow_map_size=int(shadow_map_size), strand_opacity=float(-np.log(1.0 - SHADOW_ALPHA)),
                shadow_density=1.0, pcf=1, draw_head=False, stray_fraction=0.0, clump_radius=0.004,
                density_resolution=64)


def shadow_renderer(ctx, groom, settings: dict, **changes):
    """A Renderer (no profiler) of ``settings`` with ``changes``, the groom set; the caller releases it."""
    from ..render import Renderer, RenderSettings

    r = Renderer(RenderSettings(**{**settings, **changes}), ctx=ctx, profile=False)
    r.set_strands(groom)
    return r


def points_near_segments(seg: dict, m: int, rng) -> np.ndarray:
    """m points 2..8 mm (uniform) in random directions from the midpoints of random segments
    (``seg["p0"]``, ``seg["p1"]``), drawn from ``rng``."""
    k = rng.integers(0, len(seg["p0"]), m)
    off = rng.normal(size=(m, 3))
    off /= np.linalg.norm(off, axis=1, keepdims=True)
    return 0.5 * (seg["p0"][k] + seg["p1"][k]) + off * rng.uniform(0.002, 0.008, (m, 1))


def shadows(ctx, cfg, image_dir, log) -> dict:
    from ..render.capture import capture_segments
    from ..render.shadow_probe import probe_visibility
    from .render_bench import shadow_methods

    from ..twins import shadow as ref
    light = shadow_light()
    base = shadow_settings(cfg["shadow_map_size"])
    groom = curtain_groom()

    def make(**kw):
        return shadow_renderer(ctx, groom, base, **kw)

    log("shadows: exact ray cast")
    r = make(shadows="none")
    try:
        r.render(None, [light])
        seg = ref.segments_for_reference(capture_segments(r, view=r.light_view(light)))
    finally:
        r.release()
    rng = np.random.default_rng(1)
    m = int(cfg["shadow_near"])
    near = points_near_segments(seg, m, rng)
    ny, nx = cfg["shadow_slice"]
    ys, xs = np.linspace(0.11, -0.11, ny), np.linspace(-0.045, 0.045, nx)
    gx, gy = np.meshgrid(xs, ys)
    plane = np.c_[gx.ravel(), gy.ravel(), np.zeros(gx.size)]      # the slice z = 0 through the curtain
    points = np.concatenate([near, plane])
    t0 = time.perf_counter()
    exact = ref.exact_transmittance(points, seg["p0"], seg["p1"], seg["w0"], seg["w1"], seg["strand"],
                                    light.vector, SHADOW_ALPHA)
    rows = [{"method": "none (no shadow)", "status": "ok", "reason": None,
             "mean_abs_error": float(np.abs(1.0 - exact).mean()), "bias": float(np.mean(1.0 - exact)),
             "max_abs_error": float(np.abs(1.0 - exact).max())}]
    slices = {}
    for method in [x for x in shadow_methods() if x != "none"]:
        log(f"shadows: {method}")
        row = {"method": method, "status": "ok", "reason": None}
        try:
            r = make(shadows=method)
            try:
                r.render(None, [light])
                got = probe_visibility(r, points).astype(np.float64)
            finally:
                r.release()
            err = got - exact
            row.update(mean_abs_error=float(np.abs(err).mean()), bias=float(err.mean()),
                       max_abs_error=float(np.abs(err).max()),
                       mean_abs_error_near_strands=float(np.abs(err[:m]).mean()),
                       in_range=bool(np.isfinite(got).all() and (got >= 0).all() and (got <= 1 + 1e-6).all()))
            slices[method] = got[m:].reshape(ny, nx)
        except Exception as exc:
            row.update(status="error", reason=f"{type(exc).__name__}: {exc}"[:400])
        rows.append(row)
    out = {"status": "ok", "reason": None, "methods": rows, "points": int(len(points)),
           "segments": int(len(seg["p0"])), "exact_seconds": time.perf_counter() - t0,
           "setup": f"curtain of 50 wavy guides x 4 strands, 1 mm wide, alpha {SHADOW_ALPHA} per strand crossing, "
                    f"light direction {tuple(round(float(v), 3) for v in light.vector)}, maps "
                    f"{cfg['shadow_map_size']}^2, PCF 1, density grid 64^3; {m} points 2-8 mm from strands and a "
                    f"{nx}x{ny} slice z = 0",
           "measure": "absolute transmittance error against prod(1 - alpha) over the strands each point's ray "
                      "to the light crosses (the drawn, captured segments)"}
    if image_dir is not None:
        exact_img = exact[m:].reshape(ny, nx)
        cols = 1 + len(slices)
        fig, axes = _figure(cols, 2, size=(1.6, 3.0))
        kw = dict(vmin=0, vmax=1, cmap="gray", aspect="auto")
        _imshow(axes[0][0], exact_img, "exact ray cast", **kw)
        axes[1][0].axis("off")
        for j, (method, img) in enumerate(slices.items(), start=1):
            e = next(r["mean_abs_error"] for r in rows if r["method"] == method)
            _imshow(axes[0][j], img, f"{method}\nmean |err| {e:.3f}", **kw)
            _imshow(axes[1][j], img - exact_img, "method - exact", vmin=-0.5, vmax=0.5, cmap="coolwarm",
                    aspect="auto")
        fig.suptitle("Shadows: light-0 transmittance on the slice z = 0 through the curtain", fontsize=9)
        fig.tight_layout()
        out["image"] = _save(fig, Path(image_dir) / "shadows.png")
    return out


# --------------------------------------------------------------------------- OIT
def oit(ctx, cfg, image_dir, log) -> dict:
    import trimesh

    from ..groom import Groom
    from ..mesh import Mesh
    from ..render import Camera, Light, Renderer, RenderSettings
    from ..render.oit import METHODS
    from ..render.oit.compute import COMPUTE_METHODS

    from ..twins import oit as ref
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 8)[:, None]
    strands = []
    for _ in range(48):
        x0, z0, ph = rng.uniform(-0.05, 0.05), rng.uniform(-0.04, 0.04), rng.uniform(0, 6.28)
        strands.append(np.c_[x0 + 0.012 * np.sin(5 * t + ph), 0.1 - 0.22 * t, z0 + 0.01 * np.cos(4 * t + ph)])
    groom = Groom.from_strands(strands)
    s = trimesh.creation.icosphere(subdivisions=3, radius=0.04)
    head = Mesh(np.asarray(s.vertices) + (0.0, 0.0, -0.07), np.asarray(s.faces))
    cam = Camera(eye=(0.0, -0.01, 0.45), target=(0.0, -0.01, 0.0), fov_y=30.0, near=0.05, far=3.0)
    lights = [Light(intensity=2.0)]
    base = dict(size=tuple(cfg["oit_size"]), msaa=1, shadows="none", background=(0.16, 0.17, 0.19),
                strands_per_guide=8, width=0.0012, oit_opacity=0.6, segments=16, rasterizer="hardware")
    log("oit: exact reference (all fragments, sorted in NumPy)")
    reference = ref.reference(RenderSettings(**base), groom, head, cam, lights, ctx)
    # the compute rasteriser's methods against the exact sort of the compute rasteriser's fragments
    log("oit: exact reference of the compute rasteriser's fragments")
    references = {"hardware": reference,
                  "compute": ref.compute_reference(RenderSettings(**{**base, "rasterizer": "compute"}), groom, head,
                                                   cam, lights, ctx)}
    per_pixel = np.bincount(reference["fragments"]["pixel"])
    rows, images = [], {}
    runs = [(m, "hardware") for m in ("none",) + tuple(METHODS)] + [(m, "compute") for m in COMPUTE_METHODS]
    for method, raster in runs:
        label = method if raster == "hardware" else f"{method} (compute)"
        log(f"oit: {label}")
        row = {"method": label, "rasterizer": raster, "status": "ok", "reason": None}
        try:
            r = Renderer(RenderSettings(**{**base, "oit": method, "rasterizer": raster}), ctx=ctx, profile=False)
            try:
                r.set_strands(groom)
                r.set_head(head)
                for _ in range(2):      # the second frame after pool growth / the DBK shift calibration
                    img = r.render_image(cam, lights)
                st = r.stats()
            finally:
                r.release()
            row.update(ref.image_error(img, references[raster]["image"]))
            row.update({k: st.get(k) for k in ("oit_bytes", "oit_overflow", "oit_k") if k in st})
            images[label] = (img, references[raster]["image"])
        except Exception as exc:
            row.update(status="error", reason=f"{type(exc).__name__}: {exc}"[:400])
        rows.append(row)
    out = {"status": "ok", "reason": None, "methods": rows,
           "fragments": int(len(reference["fragments"]["pixel"])), "max_depth": int(per_pixel.max()),
           "setup": f"48 wavy guides x 8 strands, alpha 0.6, over a sphere, {base['size'][0]}x{base['size'][1]}",
           "measure": "absolute difference from the exact image in [0, 1] (of 255): mean, max, p99; pixels off "
                      "by more than 1/255; '(compute)' rows: the compute rasteriser's form against the exact sort "
                      "of the compute rasteriser's fragments"}
    if image_dir is not None:
        n = len(images)
        fig, axes = _figure(n + 1, 2, size=(1.9, 1.6))
        _imshow(axes[0][0], reference["image"], "exact sort")
        axes[1][0].axis("off")
        for j, (method, (img, exact)) in enumerate(images.items(), start=1):
            e = next(r for r in rows if r["method"] == method)
            _imshow(axes[0][j], img, f"{method}\nmean {e['mean'] * 255:.2f}/255")
            d = np.clip(np.abs(img.astype(np.int16) - exact.astype(np.int16)) * 4, 0, 255)
            _imshow(axes[1][j], d.astype(np.uint8), "4x |difference|")
        fig.suptitle("Transparency: each method against the exact per-pixel sort", fontsize=9)
        fig.tight_layout()
        out["image"] = _save(fig, Path(image_dir) / "oit.png")
    return out


# --------------------------------------------------------------------------- simulation
def simulation(ctx, cfg, image_dir, log) -> dict:
    from ..groom import Groom
    from ..sim import SimSettings, Simulator, Sphere, head_motion
    from .sim_bench import HEAD_CENTER, HEAD_RADIUS, NECK_PIVOT, scalp_groom

    S, N, steps = int(cfg["sim_strands"]), int(cfg["sim_points"]), int(cfg["sim_steps"])
    log(f"simulation: {S} x {N} strands nodding, {steps} steps")
    head = Sphere(center=tuple(HEAD_CENTER), radius=HEAD_RADIUS * 0.98, friction=0.2, follow_head=True)
    sim = Simulator(scalp_groom(S, N), [head], SimSettings(length_method="dftl"), ctx, points_per_strand=N)
    motion = head_motion.preset("nod", pivot=NECK_PIVOT)
    series = {"time": [], "max_length_error": [], "max_root_error": [], "max_penetration": [], "kinetic_energy": []}
    try:
        for _ in range(steps):
            sim.set_head_transform(motion(sim.state.time + sim.settings.dt))
            sim.step()
            series["time"].append(float(sim.state.time))
            series["max_length_error"].append(float(sim.max_length_error()))
            series["max_root_error"].append(float(sim.max_root_error()))
            series["max_penetration"].append(float(sim.max_penetration()))
            series["kinetic_energy"].append(float(sim.kinetic_energy()))
        pos = sim.positions()
        nan = int(sim.nan_recoveries)
        finite = bool(np.isfinite(pos).all())
    finally:
        sim.release()
    # a hanging chain released horizontally settles: energy decays to ~0
    log("simulation: a chain settling")
    chain = np.c_[np.linspace(0.0, 0.3, 16), np.full(16, 1.0), np.zeros(16)]
    csim = Simulator(Groom.from_strands([chain]), (), SimSettings(damping=3.0, dt=1 / 60), ctx)
    energy = []
    try:
        for _ in range(int(cfg["chain_steps"])):
            csim.step()
            energy.append(float(csim.kinetic_energy()))
        p = csim.positions().astype(np.float64)
    finally:
        csim.release()
    d = (p[-1] - p[0]) / max(np.linalg.norm(p[-1] - p[0]), 1e-30)
    e = np.array(energy)
    out = {"status": "ok", "reason": None,
           "scalp": {"strands": S, "points": N, "steps": steps, "motion": "nod about the neck",
                     "max_length_error_m": max(series["max_length_error"]),
                     "max_root_error_m": max(series["max_root_error"]),
                     "max_penetration_m": max(series["max_penetration"]),
                     "nan_recoveries": nan, "finite": finite},
           "chain": {"steps": len(energy), "final_direction_y": float(d[1]),
                     "energy_peak": float(e.max()) if len(e) else None,
                     "energy_last_quarter_over_peak": float(e[-len(e) // 4:].mean() / e.max()) if len(e) and e.max() > 0
                     else None},
           "series": series}
    if image_dir is not None:
        fig, axes = _figure(3, 1, size=(3.6, 2.8))
        a, b, c = axes[0]
        a.semilogy(series["time"], np.maximum(series["max_length_error"], 1e-12), label="max length error")
        a.semilogy(series["time"], np.maximum(series["max_root_error"], 1e-12), label="max root error")
        a.semilogy(series["time"], np.maximum(series["max_penetration"], 1e-12), label="max penetration")
        a.set_xlabel("s")
        a.set_ylabel("m")
        a.legend(fontsize=6)
        a.set_title(f"scalp {S} x {N}, nodding", fontsize=8)
        b.plot(series["time"], series["kinetic_energy"])
        b.set_xlabel("s")
        b.set_title("kinetic energy (scalp)", fontsize=8)
        c.semilogy(np.arange(len(e)) / 60.0, np.maximum(e, 1e-15))
        c.set_xlabel("s")
        c.set_title("kinetic energy: a chain settling", fontsize=8)
        fig.suptitle("Simulation invariants", fontsize=9)
        fig.tight_layout()
        out["image"] = _save(fig, Path(image_dir) / "simulation.png")
    return out


# --------------------------------------------------------------------------- the target
SECTIONS = {"shading": shading, "shadows": shadows, "oit": oit, "simulation": simulation}


def run(ctx, mode: str = "default", progress=None, image_dir=None, sections=None) -> dict:
    """Every section (or ``sections``); images under ``image_dir`` when given. The JSON object."""
    if mode not in MODE_CONFIG:
        raise ValueError(f"unknown mode {mode!r}; one of {', '.join(MODE_CONFIG)}")
    cfg = MODE_CONFIG[mode]
    started = time.perf_counter()

    def log(msg):
        if progress is not None:
            progress(f"[{time.perf_counter() - started:7.1f} s] {msg}")

    body = {}
    for name in sections or SECTIONS:
        t0 = time.perf_counter()
        try:
            body[name] = SECTIONS[name](ctx, cfg, image_dir, log)
        except Skip as exc:
            body[name] = {"status": "skipped", "reason": str(exc)}
            log(f"{name}: skipped: {exc}")
        except Exception as exc:  # one broken harness must not lose the others
            body[name] = {"status": "error", "reason": f"{type(exc).__name__}: {exc}"[:400],
                          "traceback": traceback.format_exc(limit=5)}
            log(f"{name}: error: {type(exc).__name__}: {exc}")
        body[name]["seconds"] = time.perf_counter() - t0
        if image_dir is not None and "image" not in body[name]:
            body[name]["image"] = _note_figure(Path(image_dir) / f"{name}.png",
                                               f"{name}: {body[name]['status']}: {body[name].get('reason')}")
    settings = {k: (list(v) if isinstance(v, tuple) else v) for k, v in cfg.items()}
    settings["reference"] = "mane.twins"
    meta = envelope(ctx, target="quality", mode=mode, settings=settings,
                    timing={"total_seconds": time.perf_counter() - started})
    return {"meta": meta, **body}


def format_text(result: dict) -> str:
    meta = result.get("meta", {})
    out = [title_line(meta)]
    sh = result.get("shading", {})
    if sh.get("status") == "ok":
        out.append(table(sh["models"], [("model", "model", "{}"), ("max rel err", "max_rel_error", "{:.2e}"),
                                        ("p95 rel err", "p95_rel_error", "{:.2e}"),
                                        ("max |err|/peak", "max_abs_over_peak", "{:.2e}"),
                                        ("mean |err|/mean", "mean_abs_over_mean", "{:.2e}"), ("status", "status", "{}"),
                                        ("against", "against", "{}")],
                         title="\nshading: GLSL vs reference"))
    else:
        out.append(f"\nshading: {sh.get('status')}: {sh.get('reason')}")
    sd = result.get("shadows", {})
    if sd.get("status") == "ok":
        out.append(table(sd["methods"], [("method", "method", "{}"), ("mean |err|", "mean_abs_error", "{:.4f}"),
                                         ("bias", "bias", "{:+.4f}"), ("max |err|", "max_abs_error", "{:.3f}"),
                                         ("status", "status", "{}")],
                         title="\nshadows: transmittance vs the exact ray cast"))
    else:
        out.append(f"\nshadows: {sd.get('status')}: {sd.get('reason')}")
    oi = result.get("oit", {})
    if oi.get("status") == "ok":
        out.append(table(oi["methods"], [("method", "method", "{}"), ("mean", lambda r: (r.get("mean") or 0) * 255,
                                                                       "{:.2f}"),
                                         ("max", lambda r: (r.get("max") or 0) * 255, "{:.0f}"),
                                         ("px > 1/255", "pixels_over_1_255", "{}"), ("status", "status", "{}")],
                         title="\nOIT: image vs the exact sort (differences of 255)"))
    else:
        out.append(f"\nOIT: {oi.get('status')}: {oi.get('reason')}")
    si = result.get("simulation", {})
    if si.get("status") == "ok":
        s, c = si["scalp"], si["chain"]
        out.append(f"\nsimulation: max length error {fmt(s['max_length_error_m'], '{:.2e}')} m, root error "
                   f"{fmt(s['max_root_error_m'], '{:.2e}')} m, penetration {fmt(s['max_penetration_m'], '{:.2e}')} m, "
                   f"NaN recoveries {s['nan_recoveries']}; chain settles to direction y "
                   f"{fmt(c['final_direction_y'], '{:.4f}')}, energy (last quarter / peak) "
                   f"{fmt(c['energy_last_quarter_over_peak'], '{:.1e}')}")
    else:
        out.append(f"\nsimulation: {si.get('status')}: {si.get('reason')}")
    return "\n".join(out)


def run_cli(args) -> int:
    """``mane bench quality --out DIR``: DIR/quality.json, DIR/quality/*.png, the tables on stdout."""
    from ..gpu import get_context

    mode = "quick" if args.quick else "full" if args.full else "default"
    out_dir = Path(args.out) if args.out else None
    progress = None if args.quiet else (lambda msg: print(f"mane bench quality: {msg}", file=sys.stderr, flush=True))
    result = sanitise(run(get_context(), mode, progress,
                           image_dir=(out_dir / "quality") if out_dir is not None else None))
    text = to_json(result)
    if out_dir is not None:
        write_result(out_dir, "quality.json", text)
    print(text if args.json else format_text(result))
    if out_dir is not None and not args.json:
        print(f"\nwritten to {out_dir}/quality.json and {out_dir}/quality/*.png")
    return 0


__all__ = ["run", "format_text", "run_cli", "relative_error", "MODE_CONFIG", "SECTIONS"]
