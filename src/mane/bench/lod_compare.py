"""The coverage LOD's picture against the full one: one frame of the default groom at the
default framing with ``RenderSettings.lod_depth`` as set and with it 0 (every strand drawn).

    python -m mane.bench.lod_compare --strands 1000000 --size 1920x1080 --out DIR [--rasterizer compute]

Writes ``DIR/lod_on.png``, ``DIR/lod_off.png``, ``DIR/lod_diff.png`` (|on - off| x 4) and
``DIR/lod_compare.json``: the LOD's figures (estimated depth complexity, strands kept),
GPU ms of a frame each way (the renderer's profiler, a mean of a few frames after a warm-up),
the compute rasteriser's sample counts (``HairComputePass.count_samples``) where it draws,
and the image metrics of ``mane.bench.fidelity_metrics`` (on against off, sRGB output made
linear) over the whole frame and over the hair's pixels (where the frame differs from the head
drawn alone): relative MAE, p95, luminance ratio and NVIDIA FLIP where flip-evaluator is
installed.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

GUIDES, POINTS = 6250, 17   # the scale rows' default groom (mane.bench.scale_rows)


def _frame(ctx, settings, groom, head, frames: int):
    from ..render import Renderer

    r = Renderer(settings, ctx=ctx, profile=1)   # every frame
    try:
        if groom is not None:
            r.set_strands(groom)
        r.set_head(head)
        cam = r.default_camera(points=None)
        for _ in range(2):   # compile, expand
            r.render(cam)
        ctx.finish()
        r.profiler.reset()
        t = time.perf_counter()
        for _ in range(frames):
            r.render(cam)
        ctx.finish()
        wall = (time.perf_counter() - t) * 1e3 / max(frames, 1)
        stats = r.stats()
        img = r.render_image(cam)
        counts = r.get_pass("hair_compute").count_samples(cam) if groom is not None and r.compute_raster else {}
        passes = stats.pop("passes")
        return img, {"frame_wall_ms": wall, "passes_ms": passes, "frame_ms": passes.get("frame"),
                     **{k: stats.get(k) for k in ("rendered_strands", "rasterizer", "lod_depth", "lod_keep_fraction",
                                                  "lod_depth_complexity", "strands_expanded", "strands_full",
                                                  "timing")}, **counts}
    finally:
        r.release()


def compare(ctx, strands: int, size, out: Path, lod_depth: float | None = None, rasterizer: str = "auto",
            frames: int = 5, render: dict | None = None, guides: int = GUIDES) -> dict:
    from ..bench import fidelity_metrics as fm
    from ..render import RenderSettings
    from .render_bench import Workloads

    work = Workloads()
    spg = max(1, int(strands) // int(guides))
    groom = work.groom(int(guides), POINTS)
    base = RenderSettings(size=tuple(size), strands_per_guide=spg, rasterizer=rasterizer, **(render or {}))
    on = base if lod_depth is None else base.replace(lod_depth=float(lod_depth))
    out.mkdir(parents=True, exist_ok=True)
    img_on, info_on = _frame(ctx, on, groom, work.head, frames)
    img_off, info_off = _frame(ctx, on.replace(lod_depth=0.0), groom, work.head, frames)
    img_head, _ = _frame(ctx, on, None, work.head, 1)
    from PIL import Image

    Image.fromarray(img_on).save(out / "lod_on.png")
    Image.fromarray(img_off).save(out / "lod_off.png")
    diff = np.clip(np.abs(img_on.astype(np.int32) - img_off.astype(np.int32)) * 4, 0, 255).astype(np.uint8)
    Image.fromarray(diff).save(out / "lod_diff.png")
    from ..render.passes.resolve import srgb_to_linear

    a, b = srgb_to_linear(img_on / 255.0), srgb_to_linear(img_off / 255.0)
    hair = np.any(img_off != img_head, axis=-1)
    metrics = {}
    for name, mask in (("frame", None), ("hair", hair)):
        try:
            metrics[name] = fm.all_metrics(a, b, mask, with_flip=True)
        except Exception as exc:   # no flip-evaluator: the NumPy metrics alone
            metrics[name] = dict(fm.all_metrics(a, b, mask, with_flip=False), flip=None, flip_error=str(exc))
    result = {"strands": int(guides) * spg, "guides": int(guides), "strands_per_guide": spg, "size": list(size),
              "lod_depth": on.lod_depth, "hair_pixels": int(hair.sum()), "lod_on": info_on, "lod_off": info_off,
              "metrics_on_vs_off": metrics,
              "note": "metrics: the LOD frame against the full one (sRGB output made linear); 'hair': pixels where "
                      "the full frame differs from the head alone"}
    (out / "lod_compare.json").write_text(json.dumps(result, indent=1, default=float))
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m mane.bench.lod_compare", description=__doc__.split("\n\n")[0])
    p.add_argument("--strands", type=int, default=1_000_000)
    p.add_argument("--size", default="1920x1080", help="WxH")
    p.add_argument("--out", required=True)
    p.add_argument("--lod-depth", type=float, default=None, help="default: RenderSettings' default")
    p.add_argument("--rasterizer", default="auto", choices=("auto", "hardware", "compute"))
    p.add_argument("--frames", type=int, default=5)
    a = p.parse_args(argv)
    try:
        w, h = (int(v) for v in a.size.lower().split("x"))
    except ValueError:
        p.error(f"--size must be WxH, got {a.size!r}")
    from ..gpu import get_context

    res = compare(get_context(), a.strands, (w, h), Path(a.out), a.lod_depth, a.rasterizer, a.frames)
    short = {k: res[k] for k in ("strands", "size", "lod_depth", "hair_pixels")}
    for side in ("lod_on", "lod_off"):
        short[side] = {k: res[side].get(k) for k in ("frame_wall_ms", "frame_ms", "lod_keep_fraction",
                                                     "lod_depth_complexity", "strands_expanded", "sample_visits")}
    short["hair"] = {k: res["metrics_on_vs_off"]["hair"].get(k) for k in ("relative_mae", "p95", "luminance_ratio",
                                                                          "flip")}
    print(json.dumps(short, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
