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
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import UsageError

from ..render.shading import MODELS, MULTIPLE_SCATTERING
from ..render.shading.melanin import MELANIN_MAX, preset_names

SHADINGS = tuple(MODELS)
MULTIPLE_SCATTERINGS = ("auto",) + tuple(MULTIPLE_SCATTERING)


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
        if not (0 <= e <= MELANIN_MAX and 0 <= p <= MELANIN_MAX):
            raise UsageError(f"--melanin concentrations must be in [0, {MELANIN_MAX:g}], got {melanin!r}")
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


def add_scene_arguments(parser: argparse.ArgumentParser, out: str, out_help: str) -> None:
    """The scene and the picture, as every command that draws a groom takes them: GROOM, --head,
    --out, --size (``render``, ``reference``)."""
    parser.add_argument("groom", nargs="?", help="hair file (default: the procedural default groom)")
    parser.add_argument("--head", help="head mesh (.obj .ply .glb ...), 'default' or 'none' "
                                       "(default: the default head with the default groom, none with a file)")
    parser.add_argument("--out", default=out, help=out_help)
    parser.add_argument("--size", type=_size, default=(640, 480), help="WxH pixels (default 640x480)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..render.settings import GEOMETRIES, INTERPOLATIONS, SHADOWS

    add_scene_arguments(parser, "render.png", "output .png (one frame) or .mp4 (default render.png)")
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
    parser.add_argument("--hair", default=None, help=f"hair colour preset: {preset_names()} (default brown)")
    parser.add_argument("--melanin", default=None, help="hair colour as EUMELANIN,PHEOMELANIN concentrations "
                                                       "(Chiang 2016; brown 1.3,0.2, blond 0.3,0.1, black 8,0)")
    parser.add_argument("--multiple-scattering", default=None,
                        help="auto (default: dual), dual (Zinke 2008 from the fibre model), "
                             "karis (Karis 2016's approximation), none")
    parser.add_argument("--shadows", default="deep_opacity", choices=SHADOWS)
    parser.add_argument("--aa", default="msaa4", help="none, coverage, msaa2, msaa4, msaa8, ssaa2, msaa4+ssaa2")
    parser.add_argument("--interpolation", default="catmull_rom", choices=INTERPOLATIONS)
    parser.add_argument("--geometry", default="ribbons", choices=GEOMETRIES)
    parser.add_argument("--strands-per-guide", type=int, default=None,
                        help="rendered strands per guide (default 16; a file: up to ~100,000 hairs in all)")
    parser.add_argument("--segments", type=int, default=None, help="rendered segments per strand (default 32)")
    parser.add_argument("--guides", type=int, default=1000, help="guides of the default groom (default 1000)")
    parser.add_argument("--color", default=None, help="hair colour, linear R,G,B in [0,1] (replaces melanin)")
    parser.add_argument("--stats", help="write per-pass timings and counts to this JSON file")
    parser.add_argument("--interpolation-mode", default="single", choices=("single", "multi", "hybrid"),
                        help="strand multiplication: single-strand clumps, 3-guide blend, or the blend "
                             "with a single-strand fallback where guides straddle the head (default single)")
    parser.add_argument("--shadow-lights", type=int, default=None,
                        help="lights (from the first) that cast shadows, 1..4 (default: every light, up to 4; "
                             "with only the first casting, the default three lights make the hair 1.8x too "
                             "bright against a path tracer, docs/quality.md)")
    parser.add_argument("--curl", default=None, help="render-time curl RADIUS_M[,TURNS] (e.g. 0.003,6)")
    parser.add_argument("--lod", default=None, help="distance LOD START,END metres (e.g. 1,5): fewer segments "
                                                    "and strands, wider strands with distance")
    parser.add_argument("--oit", default="none", help="hair transparency: none, sorted_blending, random_subsets, "
                                                     "a_buffer, k_buffer, dbk_buffer, shortcut (default none)")
    parser.add_argument("--oit-k", type=int, default=None, help="OIT fragments sorted per pixel (default 8; 0: all)")
    parser.add_argument("--oit-opacity", type=float, default=None,
                        help="strand opacity in the camera view for --oit (times coverage; default 1)")
    parser.add_argument("--strand-budget", type=int, default=None,
                        help="refuse --guides beyond this budget (default 5000000)")
    parser.add_argument("--max-frames", type=int, default=None,
                        help="frame budget: refuse --frames beyond it (default 10000)")
    parser.add_argument("--file-colors", dest="file_colors", action=argparse.BooleanOptionalAction, default=True,
                        help="render a groom with the colours, widths and transparency its file carries "
                             "(default; --no-file-colors: the scene's hair model; --color, --hair or --melanin imply it)")
    from .options import add_frame_arguments, add_quiet_argument
    from .settings_args import add_settings_arguments

    add_frame_arguments(parser)
    add_quiet_argument(parser)
    add_settings_arguments(parser, ("render", "sim"))   # sim: the simulator of --simulate


HAIRS_ON_A_HEAD = 100_000


def file_strands_per_guide(num_strands: int, most: int = 16) -> int:
    """Rendered strands per file strand: enough for ~100,000 hairs, 1..``most``."""
    return int(min(most, max(1, round(HAIRS_ON_A_HEAD / max(1, num_strands)))))


def _check_arguments(args, video: bool) -> None:
    """Every numeric option against its documented range, the outputs writable, the work within
    its budgets: before anything is loaded or rendered."""
    from ..io.atomic import check_output_path
    from ..render.settings import RenderSettings
    from .checks import MAX_FRAMES, frame_budget, host_memory, number, setting_number, strand_budget

    number("--frames", args.frames, lo=1, integer=True)
    number("--fps", args.fps, lo=0, hi=1000, lo_open=True)
    number("--guides", args.guides, lo=1, integer=True)
    if args.turntable is not None:
        number("--turntable", args.turntable, lo=-1e6, hi=1e6)
    for name in ("strands_per_guide", "segments", "shadow_lights", "oit_k", "oit_opacity"):
        if getattr(args, name, None) is not None:
            setting_number("--" + name.replace("_", "-"), RenderSettings, name, getattr(args, name))
    max_frames = args.max_frames if getattr(args, "max_frames", None) is not None else MAX_FRAMES
    frame_budget(args.frames, max_frames, "--frames")
    if not args.groom:   # the default groom is grown here: its size and memory first
        strand_budget(args.guides, getattr(args, "strand_budget", None), "--guides")
        host_memory(args.guides * 16 * 256, f"--guides {args.guides:,}", "ask for fewer guides")
    check_output_path(args.out, "--out")
    if args.stats:
        check_output_path(args.stats, "--stats")


def _load_scene(args):
    from ..grooming.scene import default_groom, default_head
    from .options import load_groom, load_head

    head = None
    if args.groom:
        groom = load_groom(args, args.groom)
        if args.head and args.head.lower() == "default":
            head = default_head()
    else:
        head = default_head() if (args.head or "default").lower() == "default" else None
        groom = default_groom(head if head is not None else default_head(), num_guides=max(1, args.guides))
    if args.head and args.head.lower() not in ("default", "none"):
        head = load_head(args, args.head, groom if args.groom else None)
    return groom, head


def simulator_for(groom, head, settings=None):
    """The simulator of ``render --simulate``: the head mesh it is given collided through its SDF
    (``mane.sim.colliders.head_collider``, as ``mane simulate --head``); ``settings``: SimSettings
    (default: the defaults)."""
    from ..sim import Simulator
    from ..sim.colliders import head_collider

    return Simulator(groom, colliders=[head_collider(head)] if head is not None else [], settings=settings)


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
    _check_arguments(args, video)
    lights = [parse_light(t) for t in args.light] if args.light else default_lights()
    if len(lights) > MAX_LIGHTS:
        raise UsageError(f"at most {MAX_LIGHTS} --light")
    kw = dict(size=args.size, shading=args.shading, shadows=args.shadows, interpolation=args.interpolation,
              geometry=args.geometry, **aa_settings(args.aa))
    if args.strands_per_guide is not None:
        kw["strands_per_guide"] = args.strands_per_guide
    kw["interpolation_mode"] = getattr(args, "interpolation_mode", "single")
    if getattr(args, "shadow_lights", None) is not None:
        kw["shadow_lights"] = args.shadow_lights
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
            assert len(kw["hair_color"]) == 3 and all(math.isfinite(v) and v >= 0 for v in kw["hair_color"])
        except (ValueError, AssertionError):
            raise UsageError(f"--color must be R,G,B (finite, >= 0), got {args.color!r}") from None
    opts = hair_options(args)
    if opts:
        kw["shading_options"] = opts
    kw["oit"] = getattr(args, "oit", "none") or "none"
    if getattr(args, "oit_k", None) is not None:
        kw["oit_k"] = args.oit_k
    if getattr(args, "oit_opacity", None) is not None:
        kw["oit_opacity"] = args.oit_opacity
    # a colour asked for on the command line wins over the file's own
    kw["use_file_colors"] = bool(getattr(args, "file_colors", True)) and not args.color and "melanin" not in kw.get(
        "shading_options", {})
    from .settings_args import apply_settings, changed_fields, check_settings

    check_settings(args)     # --config and --set: a bad name or value before any work
    settings = apply_settings(RenderSettings(**kw), args, "render")
    chosen = changed_fields(args, "render")
    if ({"hair_color"} & chosen or "melanin" in settings.shading_options and "melanin" not in kw.get(
            "shading_options", {})) and "use_file_colors" not in chosen:
        settings = settings.replace(use_file_colors=False)   # a colour asked for wins over the file's

    t0 = time.perf_counter()
    groom, head = _load_scene(args)
    if args.groom:
        from .options import fit_warnings

        for w in fit_warnings(groom, head):
            print(f"mane render: warning: {w}", file=sys.stderr)
        if args.strands_per_guide is None and "strands_per_guide" not in chosen:
            # a file's strands are hairs, not guides: multiply them up to a head's ~100,000 hairs
            # only (16 per strand made a 10,000-strand file 160,000 strands: 498 s on llvmpipe)
            from dataclasses import replace

            settings = replace(settings, strands_per_guide=file_strands_per_guide(groom.num_strands))
    else:   # the procedural default: its clumps sized for its guides (grooming.scene)
        from ..grooming.scene import DEFAULT_SCENE_RENDER

        settings = settings.replace(**DEFAULT_SCENE_RENDER)
    renderer = Renderer(settings, profile=1)   # a file render times every frame: its --stats and summary
    try:
        return _render(args, settings, renderer, groom, head, lights, out, video, parse_camera, t0)
    finally:
        renderer.release()


def _render(args, settings, renderer, groom, head, lights, out, video, parse_camera, t0) -> int:
    from ..errors import ManeError
    from ..io.atomic import atomic_write_path, partial_path

    sim = None
    if args.simulate:
        from ..sim import SimSettings
        from .settings_args import apply_settings

        sim = simulator_for(groom, head, apply_settings(SimSettings(), args, "sim"))
        renderer.set_strands(sim)
    else:
        renderer.set_strands(groom)
    if settings.interpolation_mode == "hybrid" and head is not None:
        from ..sim.colliders import mesh_distance

        renderer.set_colliders(sdf=mesh_distance(head))
    renderer.set_head(head)
    w, h = settings.size
    lo, hi = renderer.framing_bbox()
    camera = parse_camera(args.camera, lo, hi, w / h, points=renderer.framing_points())
    turn = args.turntable if args.turntable is not None else (0.0 if args.simulate else 360.0)
    if video and (w % 2 or h % 2):
        raise UsageError("video sizes must be even (H.264 4:2:0)")
    from ..progress import progress

    quiet = getattr(args, "quiet", False)
    frames = progress(range(args.frames), desc="render", unit="frame", quiet=quiet or args.frames <= 1)
    # one frame: a bar over the renderer's passes (a 10,000-strand file on a CPU takes minutes),
    # of every frame its still picture averages (settings.accumulate)
    still = args.frames == 1
    per_picture = 1 + int(settings.accumulate) if still and settings.accumulate > 1 else 1
    pass_bar = progress(total=len(renderer.passes) * per_picture, desc="render passes", unit="pass",
                        quiet=quiet or args.frames > 1)
    renderer.on_pass = lambda name: (pass_bar.set_postfix_str(name, refresh=False), pass_bar.update(1))
    drawn = 0
    # the output appears only when complete: frames stream into a temporary beside it, renamed
    # at the end (an interrupted video is kept as NAME.partial.mp4)
    with atomic_write_path(out, keep_partial=video) as tmp:
        writer = None
        if video:
            from ..io.video import mp4_writer

            writer = mp4_writer(tmp, args.fps)
        try:
            image = None
            for i in frames:
                if sim is not None and i > 0:
                    with renderer.profiler.section("simulate"):
                        sim.advance(1.0 / args.fps)
                    renderer.strands_changed()
                cam = camera.orbited(turn * i / args.frames) if turn else camera
                image = renderer.render_still(cam, lights) if still else renderer.render_image(cam, lights)
                drawn += bool(np.any(image != image[0, 0]))
                if writer is not None:
                    writer.append_data(image)
        except KeyboardInterrupt:
            if writer is not None:
                print(f"mane render: interrupted; the frames made so far are in {partial_path(out)}")
            raise
        finally:
            pass_bar.close()
            renderer.on_pass = None
            if writer is not None:
                writer.close()
        if not drawn:
            raise ManeError(f"the render drew nothing: every pixel of every frame is the background "
                            f"(the hair and head are outside the camera, or too small); {out} not written")
        if writer is None:
            from PIL import Image

            Image.fromarray(image).save(tmp, format="JPEG" if out.suffix.lower() in (".jpg", ".jpeg") else "PNG")
    wall = time.perf_counter() - t0
    stats = renderer.stats()
    stats["wall_s"] = round(wall, 3)
    stats["output"] = str(out)
    stats["frames_drawn"] = drawn
    if args.stats:
        with atomic_write_path(args.stats) as tmp:
            Path(tmp).write_text(json.dumps(stats, indent=2))
    passes = ", ".join(f"{k} {v:.1f}" for k, v in stats["passes"].items())
    print(f"{out}: {args.frames} frame(s) {w}x{h}, {stats['rendered_strands']} strands "
          f"({stats['guides']} guides x {settings.strands_per_guide}), {stats['rendered_segments']} segments; "
          f"ms per pass ({stats['timing']}): {passes}")
    if drawn < args.frames:
        print(f"warning: {args.frames - drawn} of {args.frames} frames show only the background")
    for warning in renderer.warnings:
        print(f"warning: {warning}")
    return 0
