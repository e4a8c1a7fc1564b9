"""``mane bench fidelity [--out DIR] [--size WxH] [--spp N] [--models ...] [--shadows ...]``:
every real-time shading model and shadow method against the path-traced reference.

    result = run(ctx, "default", progress=print, image_dir="out/fidelity")

Scenes (``SCENES``): Sintel's groom (``../shared/data/tressfx/sintel_hair.tfx``, x0.01 to
metres; 228 guides x 16 strands) brown (eumelanin 1.3, pheomelanin 0.2) and blond (0.3, 0.1),
no head; and a curly procedural groom on the default head (grooming's "curly" style). One
white directional light, black background, no ambient, 320 x 320, the renderer's default
camera; ``strand_spread`` 0 (the reference cannot tilt a fibre's shading direction off its
curve). The real-time image is the renderer's linear HDR target (``realtime_linear``: tone
mapping off, exposure 1); the reference is ``mane.reference.render`` of the very strands the
renderer expanded, with the material of the same settings (``HairMaterial.from_settings``).

Numbers per (scene, model, shadow method), over the hair pixels (reference hair coverage
>= 0.5, the head hiding what is behind it) and over the whole image
(``fidelity_metrics``): MAE, p95 absolute error, relative MAE (MAE / mean reference
luminance), luminance ratio (mean mane / mean reference luminance), RGB balance (each
channel's share of R + G + B, mane minus reference), crown / lower falloff (mean luminance of
the upper over the lower half of the hair's screen box; mane's over the reference's) and the
mean NVIDIA FLIP error (HDR); with the compute rasteriser also the hair coverage (mean HDR
alpha over the reference's coverage on the hair pixels). Pictures: reference | mane | FLIP error (magma), both sides at
one exposure (the reference hair's 99th luminance percentile to 0.9), sRGB.

Reference images are rendered as independent 64-sample passes, each in a child process, and
averaged (``mane.reference.passes``: any spp, and a Mitsuba crash is one error line, not the
end of the bench) and cached (``mane.reference.cache``: ``--cache DIR``, else
``$MANE_REFERENCE_CACHE`` or ``~/.cache/mane/reference``; each pass too), so a rerun only
renders mane.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import fidelity_metrics as fm
from .common import envelope, fmt, sanitise, table, title_line, to_json, write_result

SINTEL = "tressfx/sintel_hair.tfx"
LIGHT = ("directional", (0.35, 0.8, 0.5), (1.0, 1.0, 1.0), 3.0)


@dataclass(frozen=True)
class Scene:
    name: str
    source: str            # "sintel" or "curly"
    melanin: tuple
    head: bool = False


SCENES = {
    "sintel_brown": Scene("sintel_brown", "sintel", (1.3, 0.2)),
    "sintel_blond": Scene("sintel_blond", "sintel", (0.3, 0.1)),
    "curly_head": Scene("curly_head", "curly", (1.3, 0.2), head=True),
}

MODE_CONFIG = {
    # quick: a CI-sized run (seconds); default: the scenes, every model at the default
    # shadows and the default model with every shadow method; full: every model x every method
    "quick": dict(size=(48, 48), spp=8, scenes=("curly_head",), models=("marschner",), shadows=("deep_opacity",),
                  grid=False, curly_guides=24),
    "default": dict(size=(320, 320), spp=64, scenes=tuple(SCENES), models=None, shadows=None, grid=False,
                    curly_guides=300),
    "full": dict(size=(320, 320), spp=256, scenes=tuple(SCENES), models=None, shadows=None, grid=True,
                 curly_guides=300),
}


def data_dir() -> Path | None:
    """../shared/data (next to the source tree) or $MANE_SHARED_DATA."""
    import os

    env = os.environ.get("MANE_SHARED_DATA")
    candidates = [Path(env)] if env else []
    here = Path(__file__).resolve()
    candidates += [p / "shared" / "data" for p in here.parents[3:6]]
    for c in candidates:
        if (c / SINTEL).is_file():
            return c
    return None


def load_scene(scene: Scene, curly_guides: int = 300):
    """(groom, head or None) of a fixed scene."""
    from ..errors import UsageError

    if scene.source == "sintel":
        from ..io import load

        root = data_dir()
        if root is None:
            raise UsageError(f"Sintel's groom ({SINTEL}) was not found under ../shared/data or $MANE_SHARED_DATA")
        return load(root / SINTEL, units="cm", up="y"), None   # TressFX: centimetres, Y up
    from ..grooming import grow
    from ..grooming.scene import default_head

    head = default_head()
    return grow(head, num_strands=int(curly_guides), style="curly", points_per_strand=16, seed=0), head


def base_settings(scene: Scene, size, **overrides):
    """The real-time settings of a fixed scene: RenderSettings' defaults (its shading_options
    too) with the scene's melanin (no RGB hair_color), no ambient, black background, linear output
    (tone mapping off, exposure 1), 16 strands per guide, and ``strand_spread`` 0: the shaded
    fibre direction is the curve's own, which is all the path tracer can draw (Mitsuba's hair
    BSDF takes it from the curve it hits; a per-strand tilt of the shading tangent alone is not
    a curve), so both sides shade the same fibres (docs/quality.md, "Where the per-pixel error
    lives"); ``scalp_tint`` 0: the scalp is skin_color, as the reference's Lambertian head is
    everywhere (the tint toward the hair cost the curly head 0.16 of its luminance; docs/quality.md,
    item (7))."""
    from ..render import RenderSettings

    options = {**RenderSettings().shading_options, "melanin": tuple(scene.melanin)}   # the user's defaults + melanin
    kw = dict(size=tuple(size), strands_per_guide=16, hair_color=None, shading_options=options,
              ambient=0.0, background=(0.0, 0.0, 0.0), tone_mapping="none", exposure=1.0, supersample=1,
              strand_spread=0.0, scalp_tint=0.0)
    kw.update(overrides)
    return RenderSettings(**kw)


def drawn_strands(ctx, settings, groom, head):
    """(the renderer's expanded strands as the reference draws them, its default camera) of a
    scene under ``settings``."""
    from .. import reference
    from ..render import Renderer

    r = Renderer(settings.replace(pipeline="compute", oit="none"), ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        return reference.renderer_strands(r), r.default_camera()
    finally:
        r.release()


def realtime_linear(renderer, camera=None, lights=None) -> np.ndarray:
    """Render a still picture (``Renderer.render_still``: the mean of ``settings.accumulate``
    frames) and read the linear HDR colour it shows: (H, W, 4) float32, RGB premultiplied by
    coverage (= radiance over black) and alpha, top row first; a 2x supersampled target is
    averaged 2 x 2."""
    renderer.render_still(camera, lights)
    tex = renderer.shown_hdr()
    w, h = renderer.settings.render_size
    raw = np.frombuffer(tex.read(), np.float16 if tex.dtype == "f2" else np.float32)
    img = raw.reshape(h, w, tex.components)[::-1].astype(np.float32)
    if renderer.settings.supersample == 2:
        img = img.reshape(h // 2, 2, w // 2, 2, -1).mean(axis=(1, 3))
    return np.ascontiguousarray(img)


def still_picture(ctx, settings, groom, head, camera, lights) -> tuple[np.ndarray, str]:
    """(``realtime_linear``'s picture of the scene under ``settings`` by a Renderer made for it and
    released after, "compute" or "hardware": the rasteriser that drew it)."""
    from ..render import Renderer

    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        return realtime_linear(r, camera, lights), ("compute" if r.compute_raster else "hardware")
    finally:
        r.release()


def models() -> list[str]:
    from ..render.shading import MODELS

    return list(MODELS)


def shadow_methods() -> list[str]:
    from ..render.settings import SHADOWS

    return list(SHADOWS)


def _display(img, exposure: float) -> np.ndarray:
    from ..reference.render import to_srgb8

    return to_srgb8(img, exposure)


def side_by_side(ref, test, flip_map, exposure: float) -> np.ndarray:
    """reference | mane | FLIP error (magma) as one uint8 (H, 3W, 3) picture."""
    from matplotlib import colormaps

    heat = (colormaps["magma"](np.clip(flip_map, 0.0, 1.0))[..., :3] * 255).round().astype(np.uint8)
    return np.concatenate([_display(ref, exposure), _display(test, exposure), heat], axis=1)


def _save_png(array, path: Path) -> str:
    from PIL import Image

    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(array).save(path)
    return str(path)


def run(ctx, mode: str = "default", progress=None, *, image_dir=None, size=None, spp=None, scenes=None,
        models_=None, shadows=None, grid=None, cache_dir=None, rasterizer: str = "auto", seed: int = 0) -> dict:
    """The fidelity table; see the module doc. ``models_`` / ``shadows`` / ``scenes`` restrict
    the runs (None: the mode's); ``grid`` every model x every method (else every model at the
    default method plus the default model at every method)."""
    from .. import reference
    from ..errors import UsageError
    from ..render import RenderSettings
    from ..render.lights import Light

    cfg = dict(MODE_CONFIG[mode])
    size = tuple(size) if size is not None else cfg["size"]
    spp = int(spp) if spp is not None else cfg["spp"]
    scene_names = list(scenes) if scenes else list(cfg["scenes"])
    model_list = list(models_) if models_ else list(cfg["models"] or models())
    shadow_list = list(shadows) if shadows else list(cfg["shadows"] or shadow_methods())
    grid = cfg["grid"] if grid is None else bool(grid)
    defaults = RenderSettings()
    default_model = defaults.shading if defaults.shading in model_list else model_list[0]
    default_shadow = defaults.shadows if defaults.shadows in shadow_list else shadow_list[0]
    combos = [(m, s) for m in model_list for s in shadow_list
              if grid or s == default_shadow or m == default_model]
    say = progress or (lambda msg: None)
    image_dir = Path(image_dir) if image_dir is not None else None
    light = Light(*LIGHT)
    rows, scene_meta = [], {}
    for name in scene_names:
        if name not in SCENES:
            raise UsageError(f"unknown fidelity scene {name!r}; one of {', '.join(SCENES)}")
        scene = SCENES[name]
        try:
            groom, head = load_scene(scene, cfg["curly_guides"])
        except UsageError as exc:       # Sintel without ../shared/data: the other scenes still run
            scene_meta[name] = {"skipped": str(exc)}
            say(f"{name}: skipped ({exc})")
            continue
        base = base_settings(scene, size, shading=default_model, rasterizer=rasterizer)
        strands, camera = drawn_strands(ctx, base, groom, head)
        material = reference.HairMaterial.from_settings(base)
        t0 = time.perf_counter()
        key = reference.cache_key(strands=strands, head=head, camera=camera, lights=[light], settings=base, spp=spp,
                                  material=material, seed=seed)
        say(f"{name}: reference {size[0]}x{size[1]} at {spp} spp ({strands.count} strands, key {key})")
        ref = reference.render(strands=strands, head=head, camera=camera, lights=[light], settings=base, spp=spp,
                               material=material, seed=seed, cache_dir=cache_dir, progress=lambda m: say(f"{name}: {m}"))
        ref_secs = time.perf_counter() - t0
        cov = reference.hair_coverage(strands=strands, head=head, camera=camera, settings=base,
                                      spp=min(max(spp, 4), 16), seed=seed, cache_dir=cache_dir)
        mask = cov >= 0.5
        lum = fm.luminance(ref)
        exposure = 0.9 / max(float(np.percentile(lum[mask], 99)) if mask.any() else float(lum.max()), 1e-6)
        scene_meta[name] = {"melanin": list(scene.melanin), "head": scene.head, "strands": strands.count,
                            "points_per_strand": int(strands.points.shape[1]), "reference_key": key,
                            "reference_seconds": round(ref_secs, 2), "hair_pixels": int(mask.sum()),
                            "material": material.key(), "camera": {"eye": list(camera.eye), "target": list(camera.target),
                                                                   "fov_y": camera.fov_y},
                            "reference_mean_luminance_hair": float(lum[mask].mean()) if mask.any() else None}
        if image_dir is not None:
            scene_meta[name]["reference_image"] = _save_png(_display(ref, exposure), image_dir / f"{name}_reference.png")
        for model, shadow in combos:
            settings = base.replace(shading=model, shadows=shadow)
            rgba, raster = still_picture(ctx, settings, groom, head, camera, [light])
            img = rgba[..., :3]
            flip_whole, flip_map = fm.flip(img, ref, None)      # one FLIP map for both means
            hair = fm.all_metrics(img, ref, mask, with_flip=False)
            hair["flip"] = float(flip_map[mask].mean()) if mask.any() else float("nan")
            whole = fm.all_metrics(img, ref, None, with_flip=False)
            whole["flip"] = flip_whole
            row = {"scene": name, "model": model, "shadows": shadow, "rasterizer": raster, "hair": hair,
                   "image": {k: whole[k] for k in ("mae", "p95", "relative_mae", "luminance_ratio", "flip")},
                   # the HDR alpha is the hair's coverage with the compute rasteriser only (alpha to
                   # coverage stores alpha in each covered sample: it counts alpha twice)
                   "coverage_ratio": (float(rgba[..., 3][mask].mean() / max(cov[mask].mean(), 1e-9))
                                      if mask.any() and raster == "compute" else None)}
            if image_dir is not None:
                row["picture"] = _save_png(side_by_side(ref, img, flip_map, exposure),
                                           image_dir / f"{name}_{model}_{shadow}.png")
            say(f"{name} {model} {shadow}: luminance x{hair['luminance_ratio']:.2f}, rel. MAE "
                f"{hair['relative_mae']:.2f}, FLIP {hair['flip']:.3f}")
            rows.append(row)
    meta = envelope(ctx, target="fidelity", mode=mode,
                    settings={"size": list(size), "spp": spp, "scenes": scene_names, "models": model_list,
                              "shadows": shadow_list, "grid": grid, "light": [LIGHT[0], list(LIGHT[1]), list(LIGHT[2]),
                                                                           LIGHT[3]],
                              "rasterizer": rasterizer, "seed": seed,
                              "mitsuba": _mitsuba_version(),
                              "reference_variant": reference.resolve_variant()})
    return {"meta": meta, "scenes": scene_meta, "results": rows}


def _mitsuba_version() -> str:
    from ..reference.render import mitsuba_version

    return mitsuba_version()


def format_text(result: dict) -> str:
    cols = [("scene", "scene", "{}"), ("model", "model", "{}"), ("shadows", "shadows", "{}"),
            ("raster", "rasterizer", "{}"),
            ("lum ratio", lambda r: r["hair"]["luminance_ratio"], "{:.2f}"),
            ("rel MAE", lambda r: r["hair"]["relative_mae"], "{:.2f}"),
            ("MAE", lambda r: r["hair"]["mae"], "{:.4f}"),
            ("p95", lambda r: r["hair"]["p95"], "{:.4f}"),
            ("dR", lambda r: r["hair"]["rgb_balance"][0], "{:+.3f}"),
            ("dG", lambda r: r["hair"]["rgb_balance"][1], "{:+.3f}"),
            ("dB", lambda r: r["hair"]["rgb_balance"][2], "{:+.3f}"),
            ("falloff", lambda r: r["hair"].get("falloff"), "{:.2f}"),
            ("ref falloff", lambda r: r["hair"].get("falloff_ref"), "{:.2f}"),
            ("FLIP hair", lambda r: r["hair"]["flip"], "{:.3f}"),
            ("FLIP img", lambda r: r["image"]["flip"], "{:.3f}"),
            ("coverage", "coverage_ratio", "{:.2f}")]
    s = result["meta"]["settings"]
    head = (f"{title_line(result['meta'])}\n  reference: Mitsuba {s.get('mitsuba')} {s.get('reference_variant')}, "
            f"{s['size'][0]}x{s['size'][1]}, {s['spp']} spp; hair pixels (reference coverage >= 0.5)")
    return head + "\n" + table(result["results"], cols)


def format_markdown(result: dict) -> str:
    """The results as a Markdown table (hair pixels; the whole image's FLIP beside), for docs."""
    head = ("| scene | model | shadows | raster | luminance ratio | relative MAE | MAE | p95 | RGB balance (R, G, B) "
            "| falloff (ref) | FLIP hair | FLIP image |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in result["results"]:
        h = r["hair"]
        bal = ", ".join(fmt(x, "{:+.3f}") for x in h["rgb_balance"])
        lines.append(f"| {r['scene']} | {r['model']} | {r['shadows']} | {r['rasterizer']} | "
                     f"{fmt(h['luminance_ratio'], '{:.2f}')} | {fmt(h['relative_mae'], '{:.2f}')} | "
                     f"{fmt(h['mae'], '{:.4f}')} | {fmt(h['p95'], '{:.4f}')} | {bal} | "
                     f"{fmt(h.get('falloff'), '{:.2f}')} ({fmt(h.get('falloff_ref'), '{:.2f}')}) | "
                     f"{fmt(h['flip'], '{:.3f}')} | {fmt(r['image']['flip'], '{:.3f}')} |")
    return head + "\n".join(lines) + "\n"


def run_cli(args) -> int:
    """``mane bench fidelity [--out DIR]``: DIR/fidelity.json and DIR/fidelity/*.png
    (``--decompose``: fidelity_decompose.run_cli)."""
    from ..gpu import get_context

    mode = "quick" if args.quick else "full" if args.full else "default"
    out_dir = Path(args.out) if args.out else None
    progress = None if args.quiet else (lambda msg: print(f"mane bench fidelity: {msg}", file=sys.stderr, flush=True))

    def listed(text):
        return [t.strip() for t in text.split(",") if t.strip()] if text else None

    result = sanitise(run(get_context(), mode, progress, image_dir=(out_dir / "fidelity") if out_dir else None,
                           size=getattr(args, "size", None), spp=getattr(args, "spp", None),
                           scenes=listed(getattr(args, "scenes", None)), models_=listed(getattr(args, "models", None)),
                           shadows=listed(getattr(args, "shadows", None)), cache_dir=getattr(args, "cache", None),
                           rasterizer=getattr(args, "rasterizer", None) or "auto",
                           grid=True if getattr(args, "grid", False) else None))
    text = to_json(result)
    if out_dir is not None:
        write_result(out_dir, "fidelity.json", text)
    print(text if args.json else format_text(result))
    return 0


__all__ = ["run", "run_cli", "format_text", "format_markdown", "realtime_linear", "still_picture", "base_settings", "load_scene", "side_by_side",
           "SCENES", "MODE_CONFIG", "Scene", "fmt"]
