"""Options shared by the commands that read grooms and heads: units, up axes, scales, quiet.

    add_frame_arguments(parser)           # --units --up --scale  --head-units --head-up --head-scale
    groom = load_groom(args, path)        # mane.load with the groom's options
    head = load_head(args, path, groom)   # mane.load_mesh with the head's, in the groom's frame
                                          # when the head's stored coordinates fit the groom's

``info``, ``convert``, ``render``, ``simulate``, ``view`` (and any new command that loads hair)
use these, so every command reads files the same way (mane.io.units says how guesses are made).
"""
from __future__ import annotations

import argparse
import sys
import warnings

from ..io.units import UNIT_CHOICES, UP_CHOICES


def add_frame_arguments(parser: argparse.ArgumentParser, head: bool = True, groom: bool = True) -> None:
    """--units/--up/--scale for the groom and --head-units/--head-up/--head-scale for --head."""
    if groom:
        g = parser.add_argument_group("groom units and axes (default auto: declared, convention or guessed)")
        g.add_argument("--units", choices=UNIT_CHOICES, type=str.lower, default="auto",
                       help="the hair file's unit (default auto)")
        g.add_argument("--up", choices=UP_CHOICES, type=str.lower, default="auto",
                       help="the hair file's up axis, turned to Y (default auto)")
        g.add_argument("--scale", type=float, default=None,
                       help="metres per file unit, instead of --units (e.g. 0.0254 for inches)")
    if head:
        h = parser.add_argument_group("head units and axes (default: the groom's when the head fits it "
                                      "as stored, else auto)")
        h.add_argument("--head-units", choices=UNIT_CHOICES, type=str.lower, default="auto",
                       help="the head mesh's unit (default auto)")
        h.add_argument("--head-up", choices=UP_CHOICES, type=str.lower, default="auto",
                       help="the head mesh's up axis (default auto)")
        h.add_argument("--head-scale", type=float, default=None,
                       help="metres per head-mesh unit, instead of --head-units")


def add_quiet_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quiet", "-q", action="store_true",
                        help="no progress bars (they are off anyway when stderr is not a terminal)")


def load_groom(args, path):
    from ..io import load

    return load(path, units=getattr(args, "units", "auto"), up=getattr(args, "up", "auto"),
                scale=getattr(args, "scale", None))


def load_head(args, path, groom=None):
    from ..io import load_mesh

    return load_mesh(path, units=getattr(args, "head_units", "auto"), up=getattr(args, "head_up", "auto"),
                     scale=getattr(args, "head_scale", None), like=groom)


def fit_warnings(groom, head) -> list[str]:
    """The checks a user needs before a render or a simulation: roots inside or far from the
    head, units that do not look like hair."""
    from ..io.units import check_fit, plausibility

    out = plausibility(groom)
    if head is not None:
        out += check_fit(groom, head)["warnings"]
    return out


class one_line_warnings:
    """Within: Python warnings print as ``mane CMD: warning: MESSAGE`` (one line, stderr)."""

    def __init__(self, command: str):
        self.command = command

    def __enter__(self):
        self._old = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            print(f"mane {self.command}: warning: {message}", file=sys.stderr)

        warnings.showwarning = show
        return self

    def __exit__(self, *exc):
        warnings.showwarning = self._old
        return False
