"""``mane grow``: grow a procedural groom on the default head or a mesh and save it.

    mane grow --style curly --strands 20000 --points 32 --out curly.npz
    mane grow --mesh head.obj --style wavy --length 0.3 --blue-noise --out wavy.usda

Prints one summary line: strands, points, style, lengths, bounding box, time, output path.
"""
from __future__ import annotations

import argparse
import time

from ..errors import UsageError

HELP = "grow a procedural groom on the default head or a mesh"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..grooming.styles import PRESETS

    parser.add_argument("--mesh", help="a head mesh (.obj .ply .glb .gltf .stl .tfxmesh); "
                        "default: the procedural head. Without a painted scalp (red vertex colour) "
                        "hair grows on the whole mesh")
    parser.add_argument("--style", default="straight", choices=sorted(PRESETS),
                        help="style preset (default straight)")
    parser.add_argument("--strands", type=int, default=10000, help="number of strands (default 10000)")
    parser.add_argument("--points", type=int, default=32, help="points per strand (default 32)")
    parser.add_argument("--length", type=float, help="mean strand length in metres (default: the preset's)")
    parser.add_argument("--curl-radius", type=float, help="curly: helix radius in metres")
    parser.add_argument("--curl-pitch", type=float, help="curly: helix rise per turn in metres")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--blue-noise", action="store_true",
                        help="place roots by Poisson-disk sampling instead of uniformly at random")
    parser.add_argument("--strand-budget", type=int, default=None,
                        help="refuse --strands beyond this budget (default 5000000)")
    parser.add_argument("--out", required=True, help="output hair file (.npz .usda .hair .ply ...)")
    from .options import add_frame_arguments

    add_frame_arguments(parser, groom=False)   # --head-units/--head-up/--head-scale for --mesh


def run(args) -> int:
    from pathlib import Path

    from ..grooming import default_head, grow
    from ..io import HAIR_FORMATS, save

    suffix = Path(args.out).suffix.lower()
    if suffix not in HAIR_FORMATS or not HAIR_FORMATS[suffix][2]:
        writable = sorted(s for s, e in HAIR_FORMATS.items() if e[2])
        raise UsageError(f"--out {args.out}: cannot write {suffix or 'files without a suffix'} "
                         f"hair files; use one of {', '.join(writable)}")
    from ..io.atomic import check_output_path
    from .checks import GROW_BYTES_PER_POINT, host_memory, number, strand_budget

    if args.strands <= 0:
        raise UsageError(f"--strands must be positive, got {args.strands}")
    if not 2 <= args.points <= 4096:
        raise UsageError(f"--points must be in 2..4096, got {args.points}")
    number("--seed", args.seed, lo=0, hi=2**63 - 1, integer=True)
    for flag in ("length", "curl_radius", "curl_pitch"):
        if getattr(args, flag) is not None:
            number("--" + flag.replace("_", "-"), getattr(args, flag), lo=0, hi=100, lo_open=True)
    strand_budget(args.strands, args.strand_budget, "--strands")
    host_memory(args.strands * args.points * GROW_BYTES_PER_POINT,
                f"growing {args.strands:,} strands x {args.points} points", "ask for fewer strands or points")
    check_output_path(args.out, "--out")
    t0 = time.perf_counter()
    from .options import load_head

    mesh = load_head(args, args.mesh) if args.mesh else default_head()
    groom = grow(mesh, args.strands, args.style, args.points, args.seed,
                 blue_noise=args.blue_noise, length=args.length,
                 curl_radius=args.curl_radius, curl_pitch=args.curl_pitch)
    path = save(groom, args.out)
    lengths = groom.strand_lengths()
    lo, hi = groom.bbox()
    print(f"grew {groom.num_strands} strands x {args.points} points ({args.style}) on "
          f"{args.mesh or 'the default head'}: length {lengths.mean():.3f} m "
          f"(min {lengths.min():.3f}, max {lengths.max():.3f}), bbox "
          f"[{lo[0]:.3f} {lo[1]:.3f} {lo[2]:.3f}]..[{hi[0]:.3f} {hi[1]:.3f} {hi[2]:.3f}] m, "
          f"{time.perf_counter() - t0:.2f} s -> {path}")
    return 0
