"""``mane convert IN OUT [--up AXIS] [--scale S]``: read a hair file, write another format.

``--up AXIS`` says which axis is up in the loaded groom and rotates it to Y (after the
loader's own conversion: cyHair is already turned from Z-up); ``--scale S`` multiplies
positions and widths (e.g. 0.01 for centimetres to metres). Formats come from the suffixes;
round trips are exact where the target stores float32.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UsageError
from ..groom import AXES
from ..io import HAIR_FORMATS, load, save


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", help="hair file to read (" + " ".join(sorted(HAIR_FORMATS)) + ")")
    parser.add_argument("output", help="hair file to write; its suffix picks the format")
    parser.add_argument("--up", choices=sorted(AXES), type=str.lower, default=None,
                        help="the loaded groom's up axis, rotated to Y")
    parser.add_argument("--scale", type=float, default=None, help="multiply positions and widths by S")


def run(args) -> int:
    from ..io.atomic import check_output_path

    src, dst = Path(args.input), Path(args.output)
    if args.scale is not None and not (args.scale > 0 and args.scale < float("inf")):
        raise UsageError(f"--scale must be a positive finite number, got {args.scale}")
    check_output_path(dst, "output")
    groom = load(src)
    if args.up and args.up != "y":
        groom = groom.with_up_axis(args.up, "y")
    if args.scale is not None:
        if not args.scale > 0:
            raise UsageError(f"--scale must be a positive number, got {args.scale}")
        groom = groom.scaled(args.scale)
    save(groom, dst)
    fmt = groom.metadata.get("format", src.suffix.lstrip("."))
    extra = []
    if args.up and args.up != "y":
        extra.append(f"up {args.up} -> y")
    if args.scale is not None:
        extra.append(f"scale {args.scale:g}")
    print(f"{src} ({fmt}) -> {dst}: {groom.num_strands:,} strands, {groom.num_points:,} points"
          + (f" ({', '.join(extra)})" if extra else ""))
    return 0
