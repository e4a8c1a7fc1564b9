"""``mane reference [GROOM] [--head MESH] --out ref.png --spp N --size WxH``: path trace the scene
``mane render`` would draw (its expanded strands at the still picture's ``still_segments``, camera,
lights, hair material and head) with
Mitsuba 3's hair BSDF: an offline ground truth of any groom. Needs ``pip install mane[reference]``.

The groom, head, camera, light and hair options are ``mane render``'s. The picture is linear
radiance times ``--exposure``, sRGB-encoded with no tone curve; ``--out X.npy`` keeps the
linear float image (.npy). Images are cached by a hash of the scene (``--cache DIR``, ``--no-cache``).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..errors import UsageError
from ..render.shading.melanin import preset_names
from .render import SHADINGS, _load_scene, add_scene_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..render.settings import INTERPOLATIONS

    add_scene_arguments(parser, "reference.png", "output .png (sRGB) or .npy (linear float32)")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    parser.add_argument("--seed", type=int, default=0, help="sampler seed (default 0)")
    parser.add_argument("--variant", default=None, help="Mitsuba variant: scalar_rgb (default, or "
                        "$MANE_REFERENCE_VARIANT), cuda_ad_rgb (an NVIDIA GPU), llvm_ad_rgb (every CPU core), "
                        "auto (cuda_ad_rgb where it starts)")
    parser.add_argument("--max-depth", type=int, default=64, help="longest light path (default 64)")
    parser.add_argument("--exposure", type=float, default=1.0, help="multiply the radiance before sRGB (default 1)")
    parser.add_argument("--camera", default="", help="AZ,EL[,DIST_SCALE[,FOV]] degrees around the scene's "
                                                     "box, or eye=x,y,z;target=x,y,z[;fov=deg] (as mane render)")
    parser.add_argument("--light", action="append", default=None,
                        help="dir:X,Y,Z[:INTENSITY[:R,G,B]] or point:...; repeatable (default: mane render's 3 lights)")
    from ..render.settings import RenderSettings

    parser.add_argument("--shading", default=RenderSettings.shading,
                        help=f"the real-time model whose material parameters are used ({', '.join(SHADINGS)}; "
                             f"default {RenderSettings.shading}, mane render's)")
    parser.add_argument("--hair", default=None, help=f"hair colour preset ({preset_names()}), as mane render --hair")
    parser.add_argument("--melanin", default=None, help="EU,PHEO pigment concentrations (e.g. 1.3,0.2 brown, 0.3,0.1 blond)")
    parser.add_argument("--color", default=None, help="hair colour, linear R,G,B (Chiang's inversion to absorption)")
    parser.add_argument("--interpolation", default="catmull_rom", choices=INTERPOLATIONS)
    parser.add_argument("--interpolation-mode", default="single", choices=("single", "multi", "hybrid"))
    parser.add_argument("--strands-per-guide", type=int, default=None, help="rendered strands per guide (default 16)")
    parser.add_argument("--segments", type=int, default=None, help="rendered segments per strand (default 32)")
    parser.add_argument("--guides", type=int, default=1000, help="guides of the default groom (default 1000)")
    parser.add_argument("--curl", default=None, help="render-time curl RADIUS_M[,TURNS] (e.g. 0.003,6)")
    parser.add_argument("--cache", default=None, help="image cache folder (default $MANE_REFERENCE_CACHE or "
                                                      "~/.cache/mane/reference)")
    parser.add_argument("--no-cache", action="store_true", help="neither read nor write the cache")
    from .options import add_frame_arguments
    from .settings_args import add_settings_arguments

    add_frame_arguments(parser)   # --units/--up/--scale and --head-units/--head-up/--head-scale, as mane render
    add_settings_arguments(parser, ("render",))


def settings_from_args(args):
    """The RenderSettings ``mane render`` would use for the same hair options."""
    from ..render import RenderSettings

    if args.shading not in SHADINGS:
        raise UsageError(f"--shading must be one of {', '.join(SHADINGS)}; got {args.shading!r}")
    kw = dict(size=args.size, shading=args.shading, interpolation=args.interpolation,
              interpolation_mode=args.interpolation_mode)
    if args.strands_per_guide is not None:
        kw["strands_per_guide"] = args.strands_per_guide
    if args.segments is not None:
        kw["segments"] = args.segments
    try:
        if args.curl:
            c = [float(v) for v in args.curl.split(",")]
            kw["curl_radius"] = c[0]
            if len(c) > 1:
                kw["curl_frequency"] = c[1]
        options = {}
        if args.hair:
            from ..render.shading import hair_preset

            if args.melanin or args.color:
                raise UsageError("give --hair, --melanin or --color, one of them")
            options["melanin"] = hair_preset(args.hair)
            kw["hair_color"] = None
        if args.melanin:
            m = tuple(float(v) for v in args.melanin.split(","))
            if len(m) not in (1, 2) or min(m) < 0:
                raise ValueError
            options["melanin"] = (m[0], m[1] if len(m) > 1 else 0.0)
            kw["hair_color"] = None
        if args.color:
            c = tuple(float(v) for v in args.color.split(","))
            if len(c) != 3:
                raise ValueError
            kw["hair_color"] = c
    except ValueError:
        raise UsageError(f"bad --curl {args.curl!r}, --melanin {args.melanin!r} or --color {args.color!r}: "
                         "numbers separated by commas") from None
    if options:
        kw["shading_options"] = options
    from .settings_args import apply_settings

    return apply_settings(RenderSettings(**kw), args, "render")


def run(args) -> int:
    import numpy as np

    from .. import reference
    from ..render import Renderer
    from ..render.camera import parse_camera
    from ..render.lights import default_lights, parse_light

    out = Path(args.out)
    if out.suffix.lower() not in (".png", ".npy"):
        raise UsageError(f"--out must end in .png or .npy, got {out.name}")
    if args.spp < 1:
        raise UsageError("--spp must be >= 1")
    variant = reference.resolve_variant(args.variant)
    reference.mitsuba(variant)               # the one-line message before any work when it is missing
    settings = settings_from_args(args)
    lights = [parse_light(t) for t in args.light] if args.light else default_lights()
    t0 = time.perf_counter()
    groom, head = _load_scene(args)
    r = Renderer(settings.replace(pipeline="compute", oit="none"), profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        strands = reference.renderer_strands(r)
        w, h = settings.size
        lo, hi = r.framing_bbox()
        camera = parse_camera(args.camera, lo, hi, w / h)
    finally:
        r.release()
    image = reference.render(strands=strands, head=head, camera=camera, lights=lights, settings=settings,
                             spp=args.spp, seed=args.seed, max_depth=args.max_depth, cache=not args.no_cache,
                             cache_dir=args.cache, variant=variant)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".npy":
        np.save(out, image)
    else:
        reference.save_png(image, out, args.exposure)
    material = reference.HairMaterial.from_settings(settings)
    print(f"{out}: {w}x{h}, {args.spp} spp, {strands.count} strands, Mitsuba {reference.mitsuba(variant).__version__} {variant} "
          f"hair BSDF ({', '.join(f'{k}={v}' for k, v in material.key().items() if v is not None)}), "
          f"{time.perf_counter() - t0:.1f} s")
    return 0
