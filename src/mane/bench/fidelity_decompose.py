"""``mane bench fidelity --decompose [--spp N] [--scenes ...]``: what the default model's
per-pixel error against the path tracer is made of.

    result = run(ctx, "default", spp=256, scenes=["sintel_brown"], progress=print)

For each fixed scene (``fidelity.SCENES``, the bench's own settings and reference; the mean of
the seed's and the next seed's reference when both are cached): the default frame against the
reference, then the same frame with one thing changed on mane's side
(``VARIANTS``: more coverage samples, the shadow settings before 2026-12-02, one
transmittance for the direct and the multiple-scattered light, fibre-resolving shadows, no
shadows, the renderer's per-strand tangent tilt back on), each with the relative MAE per pixel and over 4 x 4
blocks, the luminance and falloff ratios and the hair coverage (mane's HDR alpha over the
reference's coverage, summed over the hair pixels). Probes on the default frame
(``probes``): both images blurred by a Gaussian of sigma 0.5, 1 and 2 pixels (the spatial scale
the error lives at); mane's image shifted by up to half a pixel (cubic, both sides blurred by
0.7 px first so that the shift's own smoothing does not count; a camera or pixel-centre
mismatch shows as a best offset away from 0); with ``split`` (``--split``), the default frame's single
and multiple scattering against the path tracer's (``scattering_split``: a second reference at
max_depth 2, and mane's frame without multiple scattering); and, when a second reference of seed 1 is in the
cache, the two references against each other (the reference's own noise; one reference is
about 1/sqrt(2) of that from the converged image); else, when the reference's 64-spp passes
are in the cache (``mane.reference.passes``), their two halves against each other (128 spp
each: the 256-spp reference's noise is about half of that; on Sintel brown 0.160 against the
two seeds' 0.165). Results in docs/quality.md, "Where the
per-pixel error lives".
"""
from __future__ import annotations

import numpy as np

from . import fidelity_metrics as fm

VARIANTS = {
    # name: mane's settings overrides on top of the bench's scene settings (fidelity.base_settings)
    "default": {},
    "strand_spread 5 (the renderer's tilt)": {"strand_spread": 5.0},
    "msaa 8 (3 x 3 grid)": {"msaa": 8},
    "msaa 16 (4 x 4 grid)": {"msaa": 16},
    "ms_shadow_footprint 0 (one transmittance for both terms)": {"ms_shadow_footprint": 0},
    "ms_shadow_footprint 4": {"ms_shadow_footprint": 4},
    "strand_opacity 1": {"strand_opacity": 1.0},
    "until 2026-12-02: opacity map 512, pcf 2, strand_opacity 0.35, one transmittance":
        {"shadow_map_size": 512, "pcf": 2, "strand_opacity": 0.35, "ms_shadow_footprint": 0},
    "opacity map 512, pcf 1, strand_opacity 0.5, one transmittance":
        {"shadow_map_size": 512, "strand_opacity": 0.5, "ms_shadow_footprint": 0},
    "opacity map 2048, strand_opacity 1, ms_shadow_footprint 8, msaa 16":
        {"shadow_map_size": 2048, "strand_opacity": 1.0, "ms_shadow_footprint": 8, "msaa": 16},
    "opacity map 2048, strand_opacity 1, one transmittance, msaa 16":
        {"shadow_map_size": 2048, "strand_opacity": 1.0, "ms_shadow_footprint": 0, "msaa": 16},
    "opacity map 2048, ms_shadow_footprint 4, msaa 8": {"shadow_map_size": 2048, "ms_shadow_footprint": 4, "msaa": 8},
    "opacity map 4096, strand_opacity 1, ms_shadow_footprint 9, msaa 16":
        {"shadow_map_size": 4096, "strand_opacity": 1.0, "ms_shadow_footprint": 9, "msaa": 16},
    "opacity layers (0.02, 0.06, 1)": {"dom_layers": (0.02, 0.06, 1.0)},
    "opacity layers (0.01, 0.04, 1)": {"dom_layers": (0.01, 0.04, 1.0)},
    "hard shadow map 2048, msaa 16": {"shadows": "shadow_map", "shadow_map_size": 2048, "shadow_bias": 1.0, "msaa": 16},
    "no shadows": {"shadows": "none"},
    "each fibre's own multiply scattered light (ms_smoothing 0, the default until 2026-12-04)": {"ms_smoothing": 0.0},
    "the multiply scattered light smoothed over 2 mm (ms_smoothing 0.002)": {"ms_smoothing": 0.002},
}
BLUR_SIGMAS = (0.5, 1.0, 2.0)
SHIFTS = (-0.5, -0.25, 0.0, 0.25, 0.5)
SHIFT_BLUR = 0.7
SINGLE_DEPTH = 2
"""The path tracer's max_depth for single scattering: the camera ray's hit and one light sample."""


def blur(img, sigma: float) -> np.ndarray:
    """Each channel of an (H, W[, C]) image blurred by a Gaussian of ``sigma`` pixels."""
    from scipy.ndimage import gaussian_filter

    a = np.asarray(img, np.float64)
    return gaussian_filter(a, (sigma, sigma) + (0.0,) * (a.ndim - 2))   # not across channels


def shifted(img, dx: float, dy: float) -> np.ndarray:
    """The image moved by (dx, dy) pixels (+x right, +y down the rows), cubic spline."""
    from scipy.ndimage import shift

    a = np.asarray(img, np.float64)
    return shift(a, (dy, dx, 0.0), order=3, mode="nearest")   # not across channels


def best_shift(test, ref, mask, shifts=SHIFTS, sigma: float = SHIFT_BLUR) -> dict:
    """Relative MAE of ``test`` moved by each (dx, dy) in shifts x shifts, both blurred by
    ``sigma`` first: {"best": (dx, dy), "best_relative_mae", "unshifted_relative_mae"}."""
    t, r = blur(test, sigma), blur(ref, sigma)
    scores = {(dx, dy): fm.relative_mae(shifted(t, dx, dy), r, mask) for dy in shifts for dx in shifts}
    best = min(scores, key=scores.get)
    return {"best": [float(best[0]), float(best[1])], "best_relative_mae": scores[best],
            "unshifted_relative_mae": scores[(0.0, 0.0)], "blur_sigma": sigma}


def pass_halves(reference, cache, folder, common: dict, seed: int, mask) -> dict | None:
    """The reference's noise from its own cached passes (``mane.reference.passes``, first
    attempts): the mean of the first half of its passes against the second half's, relative
    MAE per pixel; the whole reference's noise from the converged image is about half of that
    (each half sqrt(2) times the whole's, the difference sqrt(2) times a half's). None when the
    reference is one pass or a pass is not in the cache."""
    from ..reference.passes import pass_seed, split

    counts = split(common["spp"], reference.default_pass_spp())
    if len(counts) < 2 or len(counts) % 2:
        return None
    images = []
    for k, n in enumerate(counts):
        img = cache.load(folder, reference.cache_key(**{**common, "spp": n}, seed=pass_seed(seed, k)))
        if img is None:
            return None
        images.append(img[..., :3].astype(np.float64))
    h = len(images) // 2
    r = fm.relative_mae(np.mean(images[:h], axis=0), np.mean(images[h:], axis=0), mask)
    return {"passes": len(images), "halves_relative_mae": r, "reference_noise_estimate": 0.5 * r}


def scattering_split(full, single, ref, ref_single, mask, bins: int = 4) -> dict:
    """Single against multiple scattering: mane's picture ``full`` and the same frame without
    multiple scattering (``single``: ShadingSettings multiple_scattering "none"; the deep opacity
    map's light through the fibres stays in it) against the path tracer's ``ref`` and its single
    scattering ``ref_single`` (max_depth 2: the light's first scattering, shadowed exactly).
    Multiple scattering is each picture minus its single scattering. Reports, over ``mask``:
    the single-scattering parts against each other (relative MAE, luminance ratio), the
    multiple-scattering parts' luminance ratio and the reference's share of it, both ratios per
    ``bins`` quantiles of the reference's luminance (darkest first: where mane's shadows leak or its
    multiple scattering is spread), and the full reference against the two swaps (the reference's
    single scattering with mane's multiple scattering, and the other way): the error each part
    leaves when the other is the path tracer's."""
    lum = fm.luminance
    full, single, ref, ref_single = (np.asarray(a, np.float64)[..., :3] for a in (full, single, ref, ref_single))
    multi, ref_multi = full - single, ref - ref_single
    l_ref = lum(ref)[mask]
    edges = np.quantile(l_ref, np.linspace(0.0, 1.0, bins + 1))

    def by_bin(a, b):
        la, lb = lum(a)[mask], lum(b)[mask]
        out = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (l_ref >= lo) & (l_ref <= hi)
            out.append(float(la[sel].sum() / lb[sel].sum()) if lb[sel].sum() > 0 else float("nan"))
        return out

    return {"single": {"relative_mae": fm.relative_mae(single, ref_single, mask),
                       "luminance_ratio": fm.luminance_ratio(single, ref_single, mask)},
            "multiple": {"luminance_ratio": fm.luminance_ratio(multi, ref_multi, mask)},
            "reference_multiple_share": float(lum(ref_multi)[mask].sum() / max(lum(ref)[mask].sum(), 1e-30)),
            "single_by_reference_quartile": by_bin(single, ref_single),
            "multiple_by_reference_quartile": by_bin(multi, ref_multi),
            "reference_single_with_mane_multiple": fm.relative_mae(ref_single + multi, ref, mask),
            "mane_single_with_reference_multiple": fm.relative_mae(single + ref_multi, ref, mask)}


def numbers(img, alpha, ref, cov, mask) -> dict:
    return {"relative_mae": fm.relative_mae(img, ref, mask), "relative_mae_box4": fm.relative_mae_box(img, ref, mask, 4),
            "luminance_ratio": fm.luminance_ratio(img, ref, mask), "falloff_ratio": fm.falloff_ratio(img, ref, mask),
            "coverage_ratio": float(np.sum(alpha[mask]) / max(np.sum(cov[mask]), 1e-12))}


def run(ctx, mode: str = "default", progress=None, *, spp=None, size=None, scenes=None, variants=None,
        cache_dir=None, seed: int = 0, split: bool = False) -> dict:
    """The decomposition table (module doc); ``variants`` a dict like ``VARIANTS`` (default it);
    ``split``: also the single / multiple scattering split of the default frame
    (``scattering_split``; a second reference at max_depth 2, the same samples)."""
    from .. import reference
    from ..errors import GPUMemoryError, UsageError
    from ..reference import cache as _cache
    from ..render.lights import Light
    from . import fidelity
    from .common import envelope

    cfg = fidelity.MODE_CONFIG[mode]
    size = tuple(size) if size is not None else cfg["size"]
    spp = int(spp) if spp is not None else cfg["spp"]
    variants = dict(VARIANTS if variants is None else variants)
    say = progress or (lambda msg: None)
    light = Light(*fidelity.LIGHT)
    rows, probes = [], {}
    for name in (list(scenes) if scenes else list(cfg["scenes"])):
        if name not in fidelity.SCENES:
            raise UsageError(f"unknown fidelity scene {name!r}; one of {', '.join(fidelity.SCENES)}")
        scene = fidelity.SCENES[name]
        groom, head = fidelity.load_scene(scene, cfg["curly_guides"])
        base = fidelity.base_settings(scene, size, rasterizer="compute")
        strands, camera = fidelity.drawn_strands(ctx, base, groom, head)
        material = reference.HairMaterial.from_settings(base)
        common = dict(strands=strands, head=head, camera=camera, lights=[light], settings=base, spp=spp,
                      material=material)
        say(f"{name}: reference at {spp} spp")
        ref = reference.render(**common, seed=seed, cache_dir=cache_dir, progress=lambda m: say(f"{name}: {m}"))
        folder = _cache.default_dir() if cache_dir is None else cache_dir
        other = _cache.load(folder, reference.cache_key(**common, seed=seed + 1))
        first = ref
        if other is not None:       # the best reference there is: both seeds' mean
            ref = 0.5 * (first + other[..., :3])
        cov = reference.hair_coverage(strands=strands, head=head, camera=camera, settings=base,
                                      spp=min(max(spp, 4), 16), seed=seed, cache_dir=cache_dir)
        mask = cov >= 0.5
        frames = {}
        for label, overrides in variants.items():
            try:
                rgba, _ = fidelity.still_picture(ctx, base.replace(**overrides), groom, head, camera, [light])
            except GPUMemoryError as exc:   # a variant this GPU cannot hold: the others still run
                rows.append({"scene": name, "variant": label, "overrides": overrides, "skipped": str(exc)})
                say(f"{name} {label}: skipped ({exc})")
                continue
            frames[label] = rgba
            row = {"scene": name, "variant": label, "overrides": overrides,
                   **numbers(rgba[..., :3], rgba[..., 3], ref, cov, mask)}
            rows.append(row)
            say(f"{name} {label}: relative MAE {row['relative_mae']:.3f} / {row['relative_mae_box4']:.3f}")
        p = {}
        if "default" in frames:
            img = frames["default"][..., :3]
            p["blur"] = {str(s): fm.relative_mae(blur(img, s), blur(ref, s), mask) for s in BLUR_SIGMAS}
            p["shift"] = best_shift(img, ref, mask)
        p["reference_seeds"] = [seed, seed + 1] if other is not None else [seed]
        if other is not None:
            p["reference_noise"] = {"relative_mae": fm.relative_mae(other, first, mask),
                                    "relative_mae_box4": fm.relative_mae_box(other, first, mask, 4),
                                    "blur": {str(s): fm.relative_mae(blur(other, s), blur(first, s), mask)
                                             for s in BLUR_SIGMAS}}
        if split and "default" in frames:
            say(f"{name}: single-scattering reference (max_depth 2) at {spp} spp")
            ref_single = reference.render(**common, seed=seed, max_depth=SINGLE_DEPTH, cache_dir=cache_dir,
                                          progress=lambda m: say(f"{name}: {m}"))[..., :3]
            one = base.replace(**variants["default"])
            one = one.replace(shading_options={**one.shading_options, "multiple_scattering": "none"})
            single, _ = fidelity.still_picture(ctx, one, groom, head, camera, [light])
            p["scattering_split"] = scattering_split(frames["default"], single, first, ref_single, mask)
        halves = pass_halves(reference, _cache, folder, common, seed, mask)
        if halves is not None:
            p["reference_pass_halves"] = halves
        probes[name] = p
    meta = envelope(ctx, target="fidelity-decompose", mode=mode,
                    settings={"size": list(size), "spp": spp, "seed": seed, "variants": variants, "split": bool(split)})
    return {"meta": meta, "results": rows, "probes": probes}


def format_text(result: dict) -> str:
    from .common import table, title_line

    cols = [("scene", "scene", "{}"), ("variant", "variant", "{}"),
            ("rel MAE px", "relative_mae", "{:.3f}"), ("rel MAE 4x4", "relative_mae_box4", "{:.3f}"),
            ("lum", "luminance_ratio", "{:.3f}"), ("falloff", "falloff_ratio", "{:.3f}"),
            ("coverage", "coverage_ratio", "{:.3f}")]
    lines = [title_line(result["meta"]), table(result["results"], cols)]
    for name, p in result["probes"].items():
        if "blur" in p:
            lines.append(f"{name}: blurred both sides " + ", ".join(f"sigma {s}: {v:.3f}" for s, v in p["blur"].items()))
        if "shift" in p:
            s = p["shift"]
            lines.append(f"{name}: best shift {s['best']} px: {s['best_relative_mae']:.3f} "
                         f"(unshifted {s['unshifted_relative_mae']:.3f}, both blurred {s['blur_sigma']} px)")
        if "reference_noise" in p:
            n = p["reference_noise"]
            lines.append(f"{name}: reference seed 1 vs seed 0: {n['relative_mae']:.3f} / {n['relative_mae_box4']:.3f} "
                         f"(the reference is their mean)")
        if "scattering_split" in p:
            q = p["scattering_split"]
            quart = lambda xs: " / ".join(f"{x:.2f}" for x in xs)
            lines.append(f"{name}: single scattering against max_depth 2: {q['single']['relative_mae']:.3f}, "
                         f"luminance {q['single']['luminance_ratio']:.3f} (by the reference's quartile, darkest "
                         f"first: {quart(q['single_by_reference_quartile'])}); multiple scattering "
                         f"{q['multiple']['luminance_ratio']:.3f}x the reference's ({quart(q['multiple_by_reference_quartile'])}; "
                         f"its share {q['reference_multiple_share']:.2f}); the reference's single + mane's multiple "
                         f"{q['reference_single_with_mane_multiple']:.3f}, mane's single + the reference's multiple "
                         f"{q['mane_single_with_reference_multiple']:.3f}")
        if "reference_pass_halves" in p:
            h = p["reference_pass_halves"]
            lines.append(f"{name}: reference seed {p['reference_seeds'][0]}'s passes, half against half: "
                         f"{h['halves_relative_mae']:.3f} (its noise ~{h['reference_noise_estimate']:.3f})")
    return "\n".join(lines)


def run_cli(args) -> int:
    """``mane bench fidelity --decompose [--out DIR]``: the table, DIR/fidelity_decompose.json."""
    import sys
    from pathlib import Path

    from ..gpu import get_context
    from .common import sanitise, to_json, write_result

    mode = "quick" if args.quick else "full" if args.full else "default"
    progress = None if args.quiet else (lambda msg: print(f"mane bench fidelity: {msg}", file=sys.stderr, flush=True))
    scenes = [t.strip() for t in args.scenes.split(",") if t.strip()] if getattr(args, "scenes", None) else None
    result = sanitise(run(get_context(), mode, progress, spp=getattr(args, "spp", None), size=getattr(args, "size", None),
                          scenes=scenes, cache_dir=getattr(args, "cache", None), split=bool(getattr(args, "split", False))))
    text = to_json(result)
    if args.out:
        write_result(Path(args.out), "fidelity_decompose.json", text)
    print(text if args.json else format_text(result))
    return 0


__all__ = ["run", "run_cli", "format_text", "VARIANTS", "blur", "shifted", "best_shift", "numbers", "pass_halves",
           "scattering_split"]
