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
import dataclasses
from pathlib import Path

import numpy as np

from ..presets import (  # noqa: F401  (the quality levels and the demo scene: mane.presets)
    GPU,
    HEADROOM,
    SOFTWARE,
    SOFTWARE_LADDER,
    TARGET_FPS,
    Quality,
    demo_scene,
    demo_sim_settings,
)
from ..render.shading.melanin import preset_names


FORMATS = (".npz", ".hair", ".ply", ".usda", ".data", ".abc", ".tfx")


def add_arguments(parser) -> None:
    parser.add_argument("--out", default="out", help="output folder (default out: out/demo.mp4, out/demo_*)")
    parser.add_argument("--seconds", type=float, default=None, help="simulated seconds (default by quality)")
    parser.add_argument("--quality", choices=("auto", "software", "gpu"), default="auto",
                        help="workload preset (auto: by the renderer)")
    parser.add_argument("--hair", default=None, help=f"hair colour preset: {preset_names()} (default brown)")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--headless", action="store_true",
                      help="render the clip to files even when a display is available")
    mode.add_argument("--window", action="store_true", help="open the viewer (fails without a display)")
    from .settings_args import add_settings_arguments

    add_settings_arguments(parser, ("render", "sim"))


def _table(rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _round_trip(groom, out: Path) -> list[list[str]]:
    from ..io import load, save

    rows = [["format", "bytes", "write ms", "read ms", "points identical"]]
    for suffix in FORMATS:
        path = out / f"demo_groom{suffix}"
        t0 = time.perf_counter()
        save(groom, path)
        t1 = time.perf_counter()
        back = load(path)
        t2 = time.perf_counter()
        ref, note = groom, ""
        if back.uniform_count is not None and back.uniform_count != groom.uniform_count:
            # TressFX takes 4..64 points (a power of two): its writer resamples the strands
            ref, note = groom.resampled(back.uniform_count), f" (resampled to {back.uniform_count})"
        same = back.num_strands == groom.num_strands and np.array_equal(back.points, ref.points)
        rows.append([suffix, f"{path.stat().st_size:,}", f"{(t1 - t0) * 1e3:.1f}",
                     f"{(t2 - t1) * 1e3:.1f}", ("yes" if same else "NO") + note])
    return rows


def _contact_sheet(frames: list[np.ndarray], path: Path, columns: int = 3) -> None:
    from PIL import Image

    h, w = frames[0].shape[:2]
    rows = math.ceil(len(frames) / columns)
    sheet = np.zeros((rows * h, columns * w, 3), np.uint8)
    for i, f in enumerate(frames):
        r, c = divmod(i, columns)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = f
    from ..io.atomic import atomic_write_path

    with atomic_write_path(path) as tmp:
        Image.fromarray(sheet).save(tmp, format="PNG")


def _want_window(args) -> bool:
    import os

    if getattr(args, "headless", False):
        return False
    if getattr(args, "window", False):
        return True
    if os.environ.get("CI") or os.environ.get("MANE_HEADLESS"):
        return False
    from ..viewer import display_available

    return display_available()


def _run_viewer(args) -> int:
    from ..viewer import Viewer

    viewer = Viewer(demo=True, quality=args.quality, out_dir=Path(args.out), title="mane demo")
    if getattr(args, "hair", None):
        from ..render.shading import hair_preset

        viewer.color_mode, viewer.melanin = "melanin", hair_preset(args.hair)
    print(f"mane demo: the viewer on {viewer.gl_name}, quality {viewer.quality.name}; "
          "close the window to quit (--headless renders files instead)")
    try:
        from .view import apply_viewer_settings

        apply_viewer_settings(viewer, args)
        seconds = args.seconds
        n = viewer.run(seconds=seconds)
        print(f"  {n} frames, {viewer.fps:.1f} frames per second at the end; {viewer.quality_report()}")
    finally:
        viewer.close()
    return 0


def _calibrate(q: Quality, make_renderer, sim, camera, lights, changes=None):
    """Frames per second of simulation + rendering; on a software renderer below TARGET_FPS,
    cheaper settings are taken from SOFTWARE_LADDER until it holds (``changes``: RenderSettings
    fields the command line set). Returns (renderer, fps, steps taken); the simulation is reset
    afterwards."""
    settings = q.render_settings(**(changes or {}))
    renderer = make_renderer(settings)

    def measure() -> float:
        sim.advance(1.0 / q.fps)                    # warm-up: the head's distance field, programs, targets
        renderer.render_image(camera, lights)
        times = []
        for _ in range(8):     # the median frame: robust to other programs' bursts on a shared CPU
            t0 = time.perf_counter()
            sim.advance(1.0 / q.fps)
            renderer.strands_changed()
            renderer.render_image(camera, lights)
            times.append(time.perf_counter() - t0)
        return 1.0 / float(np.median(times))

    taken = []
    sim.profile = renderer.profiler.enabled = False
    fps = measure()
    for label, changes in SOFTWARE_LADDER:
        if fps >= TARGET_FPS * HEADROOM:
            break
        settings = settings.replace(**changes)
        renderer.release()
        renderer = make_renderer(settings)
        renderer.profiler.enabled = False
        taken.append(f"{label} ({fps:.1f} fps before)")
        fps = measure()
    sim.profile = renderer.profiler.enabled = True
    sim.reset()
    renderer.profiler.reset()
    return renderer, fps, taken


def run(args) -> int:
    from .settings_args import check_settings

    check_settings(args)     # --config and --set: a bad name or value before any work
    if getattr(args, "hair", None):
        from ..render.shading import hair_preset

        hair_preset(args.hair)                       # a clear error for an unknown name, first
    if _want_window(args):
        from ..errors import ManeError

        try:
            return _run_viewer(args)
        except ManeError as exc:
            if getattr(args, "window", False):
                raise
            print(f"mane demo: no viewer ({exc}); rendering headless")
    return _run_headless(args)


def _run_headless(args) -> int:
    from tqdm import tqdm

    from ..gpu import get_context, is_software_renderer, renderer_name
    from ..io import usd_curves
    from ..io.video import mp4_writer
    from ..render import Renderer
    from ..render.lights import default_lights
    from ..sim import MeshCollider, Simulator, Sphere, head_motion

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ctx = get_context()
    software = is_software_renderer(ctx)
    q = {"software": SOFTWARE, "gpu": GPU}.get(args.quality) or (SOFTWARE if software else GPU)
    if getattr(args, "hair", None):
        q = dataclasses.replace(q, hair=args.hair)
    seconds = args.seconds if args.seconds is not None else q.seconds
    print(f"mane demo on {renderer_name(ctx)}: quality {q.name}")
    if software and q.name == SOFTWARE.name:
        drawn = (q.points - 1) * math.ceil(q.segments / (q.points - 1))   # whole guide segments
        print(f"  scaled down: {q.guides} guides x {q.strands_per_guide} strands, {drawn} segments, "
              f"{q.size[0]}x{q.size[1]}, no MSAA, {q.shading} shading, {q.shadows} {q.shadow_map_size}, {q.geometry}, "
              f"{1 / q.sim_dt:.0f} Hz simulation (a GPU runs {GPU.guides} x {GPU.strands_per_guide} at "
              f"{GPU.size[0]}x{GPU.size[1]}, {GPU.msaa}x MSAA, {GPU.shading}, {GPU.shadows})")

    t0 = time.perf_counter()
    groom, head = demo_scene(q)
    st = groom.stats()
    print(f"\n1. grew the default groom in {time.perf_counter() - t0:.1f} s: {st['num_strands']} guide strands, "
          f"{st['num_points']} points, length {st['strand_length']['mean'] * 100:.1f} cm on average, "
          f"head {len(head.vertices)} vertices / {len(head.faces)} triangles")

    print(f"\n2. the groom in every writable format ({out}/demo_groom.*), read back:")
    print(_table(_round_trip(groom, out)))

    # A sphere sweeps through the hair, the head nods, wind gusts from the front-left.
    lo, hi = groom.bbox()
    centre = (lo + hi) / 2
    radius = 0.25 * float(np.max(hi - lo))
    sweep = Sphere(center=centre, radius=radius * 0.45, friction=0.3)
    cranium = MeshCollider(head, margin=0.001)  # the head's signed distance field, riding on the head
    from .settings_args import apply_settings, changed_fields

    settings = apply_settings(demo_sim_settings(q), args, "sim")
    applied = apply_settings(q.render_settings(), args, "render")
    render_changes = {k: getattr(applied, k) for k in changed_fields(args, "render")}
    sim = Simulator(groom, colliders=[cranium, sweep], settings=settings, profile=True)

    def make_renderer(render_settings):
        r = Renderer(render_settings, ctx=ctx)
        r.set_strands(sim)
        r.set_head(head)
        return r

    renderer = make_renderer(q.render_settings(**render_changes))
    camera = renderer.default_camera(25.0, 10.0)
    lights = default_lights()
    if software and q.name == SOFTWARE.name:
        renderer.release()
        renderer, fps, taken = _calibrate(q, make_renderer, sim, camera, lights, render_changes)
        if taken:
            print(f"  below {TARGET_FPS:g} fps here: scaled down further: {', '.join(taken)}")
        print(f"  simulation + rendering at {q.size[0]}x{q.size[1]}: {fps:.1f} frames per second "
              f"(target {TARGET_FPS:g})")

    frames_n = max(2, int(round(seconds * q.fps)))
    video = out / "demo.mp4"
    from ..io.atomic import atomic_write_path

    video_file = atomic_write_path(video, keep_partial=True)   # demo.mp4 appears when complete
    writer = mp4_writer(video_file.__enter__(), q.fps)
    keep = set(np.linspace(0, frames_n - 1, 6).round().astype(int).tolist())
    sheet, animation = [], []
    worst = {"max_length_error": 0.0, "max_root_error": 0.0, "max_penetration": 0.0}
    t_start = time.perf_counter()
    busy = 0.0   # seconds spent simulating and rendering (the rest: read-backs, checks, encoding)
    print(f"\n3. simulating and rendering {frames_n} frames ({seconds:g} s at {q.fps:g} fps) -> {video}")
    try:
        for i in tqdm(range(frames_n), unit="frame", desc="demo"):
            t = i / q.fps
            motion = head_motion.nod(t)
            sim.set_head_transform(motion)
            renderer.set_head_transform(motion)
            phase = 2 * math.pi * t / max(seconds, 1e-6)
            sweep.move_to(centre + radius * np.array([1.6 * math.cos(phase), 0.2, 1.6 * math.sin(phase)]))
            t_busy = time.perf_counter()
            if i:
                sim.advance(1.0 / q.fps)
                renderer.strands_changed()
            image = renderer.render_image(camera, lights)
            busy += time.perf_counter() - t_busy
            pts = sim.positions()
            animation.append(pts)
            for key in worst:
                worst[key] = max(worst[key], float(getattr(sim, key)(positions=pts)))
            writer.append_data(image)
            if i in keep:
                sheet.append(image)
    except BaseException as exc:
        writer.close()
        video_file.__exit__(type(exc), exc, exc.__traceback__)
        raise
    writer.close()
    video_file.__exit__(None, None, None)
    wall = time.perf_counter() - t_start
    _contact_sheet(sheet, out / "demo_contact_sheet.png")
    usd_curves.write(groom, out / "demo_simulation.usda", frames=animation, fps=q.fps)
    size = renderer.settings.size
    print(f"   {frames_n / max(busy, 1e-9):.1f} frames per second simulated and rendered at {size[0]}x{size[1]} "
          f"({frames_n / wall:.1f} with read-backs, checks and video encoding)")
    print(f"   {frames_n} frames over {wall:.1f} s; contact sheet {out}/demo_contact_sheet.png; "
          f"animation {out}/demo_simulation.usda ({frames_n} time samples)")

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
        "render_fps": frames_n / max(busy, 1e-9),
        "size": list(q.size), "rendered_strands": rstats.get("rendered_strands"),
        "groom": st, "sim_passes_ms": sim_ms, "render_passes_ms": rstats["passes"],
        "invariants": {**worst, "nan_recoveries": sim.nan_recoveries},
    }
    from ..io.atomic import atomic_write_path

    with atomic_write_path(out / "demo_timings.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2))
    renderer.release()
    sim.release()
    return 0
