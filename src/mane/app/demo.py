"""``mane demo``: the main job, needing no files.

Grows the procedural head's groom, writes it in every writable hair format and reads each
back, simulates it while the head nods, wind gusts and a sphere sweeps through the hair,
renders the simulation (the renderer reads the simulator's buffer directly) to an MP4 and a
contact sheet, exports the animation to USD, and prints a timing table. On a software
renderer (llvmpipe) it scales its workload down by itself and says so.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# Workloads: what a CPU rasteriser renders at interactive rates, and what a GPU shows off.
@dataclass(frozen=True)
class Quality:
    name: str
    guides: int
    strands_per_guide: int
    points: int
    segments: int
    size: tuple[int, int]
    seconds: float
    fps: float
    msaa: int


SOFTWARE = Quality("software (scaled down for a CPU rasteriser)", 300, 4, 16, 12, (480, 270), 2.0, 24.0, 1)
GPU = Quality("gpu", 4000, 16, 32, 32, (1280, 720), 4.0, 30.0, 4)

FORMATS = (".npz", ".hair", ".ply", ".usda", ".data", ".abc", ".tfx")


def add_arguments(parser) -> None:
    parser.add_argument("--out", default="out/demo", help="output folder (default out/demo)")
    parser.add_argument("--seconds", type=float, default=None, help="simulated seconds (default by quality)")
    parser.add_argument("--quality", choices=("auto", "software", "gpu"), default="auto",
                        help="workload preset (auto: by the renderer)")


def _table(rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _round_trip(groom, out: Path) -> list[list[str]]:
    from .. import load, save

    rows = [["format", "bytes", "write ms", "read ms", "points identical"]]
    for suffix in FORMATS:
        path = out / f"groom{suffix}"
        t0 = time.perf_counter()
        save(groom, path)
        t1 = time.perf_counter()
        back = load(path)
        t2 = time.perf_counter()
        same = back.num_strands == groom.num_strands and np.array_equal(back.points, groom.points)
        rows.append([suffix, f"{path.stat().st_size:,}", f"{(t1 - t0) * 1e3:.1f}",
                     f"{(t2 - t1) * 1e3:.1f}", "yes" if same else "NO"])
    return rows


def _contact_sheet(frames: list[np.ndarray], path: Path, columns: int = 3) -> None:
    from PIL import Image

    h, w = frames[0].shape[:2]
    rows = math.ceil(len(frames) / columns)
    sheet = np.zeros((rows * h, columns * w, 3), np.uint8)
    for i, f in enumerate(frames):
        r, c = divmod(i, columns)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = f
    Image.fromarray(sheet).save(path)


def run(args) -> int:
    import imageio.v2 as imageio
    from tqdm import tqdm

    from ..gpu import get_context, is_software_renderer, renderer_name
    from ..io import usd_curves
    from ..render import Renderer, RenderSettings
    from ..render.lights import default_lights
    from ..render.scene import default_scene
    from ..sim import MeshCollider, SimSettings, Simulator, Sphere, WindSettings, head_motion

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ctx = get_context()
    software = is_software_renderer(ctx)
    q = {"software": SOFTWARE, "gpu": GPU}.get(args.quality) or (SOFTWARE if software else GPU)
    seconds = args.seconds if args.seconds is not None else q.seconds
    print(f"mane demo on {renderer_name(ctx)}: quality {q.name}")
    if software and q is SOFTWARE:
        print(f"  scaled down: {q.guides} guides x {q.strands_per_guide} strands, {q.size[0]}x{q.size[1]}, "
              f"no MSAA (a GPU runs {GPU.guides} x {GPU.strands_per_guide} at {GPU.size[0]}x{GPU.size[1]}, "
              f"{GPU.msaa}x MSAA)")

    t0 = time.perf_counter()
    groom, head = default_scene(num_guides=q.guides, points=q.points)
    groom = groom.resampled(q.points)
    st = groom.stats()
    print(f"\n1. grew the default groom in {time.perf_counter() - t0:.1f} s: {st['num_strands']} guide strands, "
          f"{st['num_points']} points, length {st['strand_length']['mean'] * 100:.1f} cm on average, "
          f"head {len(head.vertices)} vertices / {len(head.faces)} triangles")

    print(f"\n2. the groom in every writable format ({out}/groom.*), read back:")
    print(_table(_round_trip(groom, out)))

    # A sphere sweeps through the hair, the head nods, wind gusts from the front-left.
    lo, hi = groom.bbox()
    centre = (lo + hi) / 2
    radius = 0.25 * float(np.max(hi - lo))
    sweep = Sphere(center=centre, radius=radius * 0.45, friction=0.3)
    cranium = MeshCollider(head, margin=0.001)  # the head's signed distance field, riding on the head
    settings = SimSettings(
        friction=0.05, local_shape_stiffness=0.05, global_shape_stiffness=0.02, global_shape_range=0.3,
        wind=WindSettings(velocity=(0.6, 0.0, 1.2), gust=1.0, turbulence=0.6),
    )
    sim = Simulator(groom, colliders=[cranium, sweep], settings=settings, profile=True)
    render_settings = RenderSettings(size=q.size, strands_per_guide=q.strands_per_guide, segments=q.segments,
                                     msaa=q.msaa, shading="marschner", shadows="deep_opacity")
    renderer = Renderer(render_settings, ctx=ctx)
    renderer.set_strands(sim)
    renderer.set_head(head)
    camera = renderer.default_camera(25.0, 10.0)
    lights = default_lights()

    frames_n = max(2, int(round(seconds * q.fps)))
    video = out / "demo.mp4"
    writer = imageio.get_writer(str(video), fps=q.fps, codec="libx264", quality=8, macro_block_size=1,
                                ffmpeg_log_level="error")
    keep = set(np.linspace(0, frames_n - 1, 6).round().astype(int).tolist())
    sheet, animation = [], []
    worst = {"max_length_error": 0.0, "max_root_error": 0.0, "max_penetration": 0.0}
    t_start = time.perf_counter()
    print(f"\n3. simulating and rendering {frames_n} frames ({seconds:g} s at {q.fps:g} fps) -> {video}")
    try:
        for i in tqdm(range(frames_n), unit="frame", desc="demo"):
            t = i / q.fps
            motion = head_motion.nod(t)
            sim.set_head_transform(motion)
            renderer.set_head_transform(motion)
            phase = 2 * math.pi * t / max(seconds, 1e-6)
            sweep.move_to(centre + radius * np.array([1.6 * math.cos(phase), 0.2, 1.6 * math.sin(phase)]))
            if i:
                sim.advance(1.0 / q.fps)
                renderer.strands_changed()
            pts = sim.positions()
            animation.append(pts)
            for key in worst:
                worst[key] = max(worst[key], float(getattr(sim, key)(positions=pts)))
            image = renderer.render_image(camera, lights)
            writer.append_data(image)
            if i in keep:
                sheet.append(image)
    finally:
        writer.close()
    wall = time.perf_counter() - t_start
    _contact_sheet(sheet, out / "contact_sheet.png")
    usd_curves.write(groom, out / "simulation.usda", frames=animation, fps=q.fps)
    print(f"   {frames_n / wall:.1f} frames per second over {wall:.1f} s; contact sheet {out}/contact_sheet.png; "
          f"animation {out}/simulation.usda ({frames_n} time samples)")

    rstats = renderer.stats()
    sim_ms = sim.pass_times()
    rows = [["pass", "ms per call"]]
    rows += [[f"sim.{k}", f"{v:.3f}"] for k, v in sim_ms.items()]
    rows += [[f"render.{k}", f"{v:.3f}"] for k, v in rstats["passes"].items()]
    print(f"\n4. timings ({rstats.get('timing', 'cpu')}, {renderer_name(ctx)}):")
    print(_table(rows))
    print("\n5. simulation invariants over the run: "
          f"length error {worst['max_length_error']:.2e} (relative), root error {worst['max_root_error']:.2e} m, "
          f"penetration {worst['max_penetration']:.2e} m, NaN recoveries {sim.nan_recoveries}")
    summary = {
        "renderer": renderer_name(ctx), "quality": q.name, "frames": frames_n, "fps": frames_n / wall,
        "size": list(q.size), "rendered_strands": rstats.get("rendered_strands"),
        "groom": st, "sim_passes_ms": sim_ms, "render_passes_ms": rstats["passes"],
        "invariants": {**worst, "nan_recoveries": sim.nan_recoveries},
    }
    (out / "timings.json").write_text(json.dumps(summary, indent=2))
    renderer.release()
    sim.release()
    return 0
