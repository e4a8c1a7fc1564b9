"""``mane render [GROOM] [--head MESH] [--out a.png|a.mp4] ...``: render a groom to an image or a video.

With no GROOM it renders the procedural default (the default head and a groom grown on it).
One frame goes to a PNG; several frames go to an MP4 (imageio-ffmpeg) with a progress bar:
a turntable around the scene, or with ``--simulate`` the simulator stepping while the
renderer reads its position buffer directly. ``--stats`` writes per-pass milliseconds.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import UsageError

SHADINGS = ("chiang", "kajiya_kay", "marschner", "marschner_lut", "sadeghi", "scheuermann", "karis")
MULTIPLE_SCATTERINGS = ("auto", "dual", "karis", "none")


def hair_options(args) -> dict:
    """ShadingSettings options from --hair PRESET, --melanin EU,PHEO and --multiple-scattering."""
    from ..render.shading import hair_preset

    opts = {}
    hair = getattr(args, "hair", None)
    melanin = getattr(args, "melanin", None)
    if hair and melanin:
        raise UsageError("give --hair PRESET or --melanin EU,PHEO, not both")
    if hair:
        opts["melanin"] = hair_preset(hair)
    if melanin:
        try:
            e, p = (float(v) for v in melanin.split(","))
        except ValueError:
            raise UsageError(f"--melanin must be EUMELANIN,PHEOMELANIN (e.g. 1.3,0.2), got {melanin!r}") from None
        if not (0 <= e <= 50 and 0 <= p <= 50):
            raise UsageError(f"--melanin concentrations must be in [0, 50], got {melanin!r}")
        opts["melanin"] = (e, p)
    if (hair or melanin) and getattr(args, "color", None):
        raise UsageError("--color replaces melanin: give --color or --hair/--melanin, not both")
    ms = getattr(args, "multiple_scattering", None)
    if ms:
        if ms not in MULTIPLE_SCATTERINGS:
            raise UsageError(f"--multiple-scattering must be one of {', '.join(MULTIPLE_SCATTERINGS)}; got {ms!r}")
        opts["multiple_scattering"] = ms
    return opts


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WxH (e.g. 320x240), got {text!r}") from None
    return w, h


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..render.settings import GEOMETRIES, INTERPOLATIONS, SHADOWS

    parser.add_argument("groom", nargs="?", help="hair file (default: the procedural default groom)")
    parser.add_argument("--head", help="head mesh (.obj .ply .glb ...), 'default' or 'none' "
                                       "(default: the default head with the default groom, none with a file)")
    parser.add_argument("--out", default="render.png", help="output .png (one frame) or .mp4 (default render.png)")
    parser.add_argument("--size", type=_size, default=(640, 480), help="WxH pixels (default 640x480)")
    parser.add_argument("--frames", type=int, default=1, help="frames to render (>1 needs an .mp4, default 1)")
    parser.add_argument("--fps", type=float, default=30.0, help="video frame rate (default 30)")
    parser.add_argument("--simulate", action="store_true",
                        help="step the simulator between frames; the renderer reads its buffer")
    parser.add_argument("--turntable", type=float, default=None,
                        help="degrees the camera turns over the frames (default 360 without --simulate, else 0)")
    parser.add_argument("--camera", default="", help="AZ,EL[,DIST_SCALE[,FOV]] degrees around the scene's "
                                                     "box, or eye=x,y,z;target=x,y,z[;fov=deg]")
    parser.add_argument("--light", action="append", default=None,
                        help="dir:X,Y,Z[:INTENSITY[:R,G,B]] or point:...; repeat for up to 3 (first casts shadows)")
    parser.add_argument("--shading", default="chiang", help=f"hair model: {', '.join(SHADINGS)} (default chiang)")
    parser.add_argument("--hair", default=None, help="hair colour preset: black, dark_brown, brown (default), "
                                                    "auburn, red, blond, platinum, grey")
    parser.add_argument("--melanin", default=None, help="hair colour as EUMELANIN,PHEOMELANIN concentrations "
                                                       "(Chiang 2016; brown 1.3,0.2, blond 0.3,0.1, black 8,0)")
    parser.add_argument("--multiple-scattering", default=None,
                        help="auto (default: dual), dual (Zinke 2008 from the fibre model), "
                             "karis (Karis 2016's approximation), none")
    parser.add_argument("--shadows", default="deep_opacity", choices=SHADOWS)
    parser.add_argument("--aa", default="msaa4", help="none, coverage, msaa2, msaa4, msaa8, ssaa2, msaa4+ssaa2")
    parser.add_argument("--interpolation", default="catmull_rom", choices=INTERPOLATIONS)
    parser.add_argument("--geometry", default="ribbons", choices=GEOMETRIES)
    parser.add_argument("--strands-per-guide", type=int, default=None, help="rendered strands per guide (default 16)")
    parser.add_argument("--segments", type=int, default=None, help="rendered segments per strand (default 32)")
    parser.add_argument("--guides", type=int, default=1000, help="guides of the default groom (default 1000)")
    parser.add_argument("--color", default=None, help="hair colour, linear R,G,B in [0,1] (replaces melanin)")
    parser.add_argument("--stats", help="write per-pass timings and counts to this JSON file")
    parser.add_argument("--interpolation-mode", default="single", choices=("single", "multi", "hybrid"),
                        help="strand multiplication: single-strand clumps, 3-guide blend, or the blend "
                             "with a single-strand fallback where guides straddle the head (default single)")
    parser.add_argument("--shadow-lights", type=int, default=1, help="lights (from the first) that cast shadows, 1..4")
    parser.add_argument("--curl", default=None, help="render-time curl RADIUS_M[,TURNS] (e.g. 0.003,6)")
    parser.add_argument("--lod", default=None, help="distance LOD START,END metres (e.g. 1,5): fewer segments "
                                                    "and strands, wider strands with distance")
    parser.add_argument("--oit", default="none", help="hair transparency: none, sorted_blending, random_subsets, "
                                                     "a_buffer, k_buffer, dbk_buffer, shortcut (default none)")
    parser.add_argument("--oit-k", type=int, default=None, help="OIT fragments sorted per pixel (default 8; 0: all)")
    parser.add_argument("--oit-opacity", type=float, default=None,
                        help="strand opacity in the camera view for --oit (times coverage; default 1)")


def _load_scene(args):
    from ..render.scene import default_groom, default_head

    head = None
    if args.groom:
        from ..io import load

        groom = load(args.groom)
        if args.head and args.head.lower() == "default":
            head = default_head()
    else:
        head = default_head() if (args.head or "default").lower() == "default" else None
        groom = default_groom(head if head is not None else default_head(), num_guides=max(1, args.guides))
    if args.head and args.head.lower() not in ("default", "none"):
        from ..io import load_mesh

        head = load_mesh(args.head)
    return groom, head


def run(args) -> int:
    from ..render import Renderer, RenderSettings
    from ..render.camera import parse_camera
    from ..render.lights import MAX_LIGHTS, default_lights, parse_light
    from ..render.settings import aa_settings

    out = Path(args.out)
    video = out.suffix.lower() in (".mp4", ".mov", ".mkv", ".webm")
    if out.suffix.lower() not in (".png", ".jpg", ".jpeg") and not video:
        raise UsageError(f"--out must end in .png or .mp4, got {out.name}")
    if args.frames < 1:
        raise UsageError("--frames must be >= 1")
    if args.frames > 1 and not video:
        raise UsageError(f"{args.frames} frames need a video: use --out NAME.mp4")
    if args.shading not in SHADINGS:
        raise UsageError(f"--shading must be one of {', '.join(SHADINGS)}; got {args.shading!r}")
    lights = [parse_light(t) for t in args.light] if args.light else default_lights()
    if len(lights) > MAX_LIGHTS:
        raise UsageError(f"at most {MAX_LIGHTS} --light")
    kw = dict(size=args.size, shading=args.shading, shadows=args.shadows, interpolation=args.interpolation,
              geometry=args.geometry, **aa_settings(args.aa))
    if args.strands_per_guide is not None:
        kw["strands_per_guide"] = args.strands_per_guide
    kw["interpolation_mode"] = getattr(args, "interpolation_mode", "single")
    kw["shadow_lights"] = getattr(args, "shadow_lights", 1)
    try:
        if getattr(args, "curl", None):
            c = [float(v) for v in args.curl.split(",")]
            kw["curl_radius"] = c[0]
            if len(c) > 1:
                kw["curl_frequency"] = c[1]
        if getattr(args, "lod", None):
            a, b = (float(v) for v in args.lod.split(","))
            kw.update(lod=True, lod_start=a, lod_end=b)
    except ValueError:
        raise UsageError(f"bad --curl {args.curl!r} or --lod {args.lod!r}: numbers separated by a comma") from None
    if args.segments is not None:
        kw["segments"] = args.segments
    if args.color:
        try:
            kw["hair_color"] = tuple(float(v) for v in args.color.split(","))
            assert len(kw["hair_color"]) == 3
        except (ValueError, AssertionError):
            raise UsageError(f"--color must be R,G,B, got {args.color!r}") from None
    opts = hair_options(args)
    if opts:
        kw["shading_options"] = opts
    kw["oit"] = getattr(args, "oit", "none") or "none"
    if getattr(args, "oit_k", None) is not None:
        kw["oit_k"] = args.oit_k
    if getattr(args, "oit_opacity", None) is not None:
        kw["oit_opacity"] = args.oit_opacity
    settings = RenderSettings(**kw)

    t0 = time.perf_counter()
    groom, head = _load_scene(args)
    renderer = Renderer(settings)
    sim = None
    if args.simulate:
        from ..sim import Simulator, Sphere

        colliders = []
        if head is not None:
            lo, hi = head.bbox()
            # the cranium: a sphere around the head's top part (the mesh collider needs an SDF bake)
            colliders.append(Sphere(center=(0.0, 0.0, -0.01), radius=0.085))
        sim = Simulator(groom, colliders=colliders)
        renderer.set_strands(sim)
    else:
        renderer.set_strands(groom)
    renderer.set_head(head)
    w, h = settings.size
    lo, hi = renderer.framing_bbox()
    camera = parse_camera(args.camera, lo, hi, w / h)
    turn = args.turntable if args.turntable is not None else (0.0 if args.simulate else 360.0)

    writer = None
    if video:
        from ..io.video import mp4_writer

        if w % 2 or h % 2:
            raise UsageError("video sizes must be even (H.264 4:2:0)")
        writer = mp4_writer(out, args.fps)
    frames = range(args.frames)
    try:
        from tqdm import tqdm

        frames = tqdm(frames, desc="render", unit="frame", disable=args.frames <= 1)
    except ImportError:  # pragma: no cover
        pass
    image = None
    try:
        for i in frames:
            if sim is not None and i > 0:
                with renderer.profiler.section("simulate"):
                    sim.advance(1.0 / args.fps)
                renderer.strands_changed()
            cam = camera.orbited(turn * i / args.frames) if turn else camera
            image = renderer.render_image(cam, lights)
            if writer is not None:
                writer.append_data(image)
    finally:
        if writer is not None:
            writer.close()
    if writer is None:
        from PIL import Image

        out.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(image).save(out)
    wall = time.perf_counter() - t0
    stats = renderer.stats()
    stats["wall_s"] = round(wall, 3)
    stats["output"] = str(out)
    if args.stats:
        Path(args.stats).write_text(json.dumps(stats, indent=2))
    passes = ", ".join(f"{k} {v:.1f}" for k, v in stats["passes"].items())
    print(f"{out}: {args.frames} frame(s) {w}x{h}, {stats['rendered_strands']} strands "
          f"({stats['guides']} guides x {settings.strands_per_guide}), {stats['rendered_segments']} segments; "
          f"ms per pass ({stats['timing']}): {passes}")
    for warning in renderer.warnings:
        print(f"warning: {warning}")
    renderer.release()
    return 0
