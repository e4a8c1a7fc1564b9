"""The ``mane`` command line: a sub-command per module in ``mane.app``.

Each command module defines ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args) -> int``. Modules are imported only when their command runs, so
``mane --help`` stays fast and a missing optional library breaks only its command.
"""
from __future__ import annotations

import argparse
import difflib
import importlib
import signal
import sys
import threading

from .. import __version__
from ..errors import ManeError

# command -> (module, one-line help). Kept here so that --help needs no imports.
COMMANDS: dict[str, tuple[str, str]] = {
    "info": ("mane.app.info", "print a hair file's strands, points, bounding box and attributes"),
    "convert": ("mane.app.convert", "convert a hair or mesh file to another format (units, up axis, --points)"),
    "grow": ("mane.app.grow", "grow a procedural groom on the default head or a mesh"),
    "render": ("mane.app.render", "render a groom (or the default head and hair) to a PNG or an MP4"),
    "reference": ("mane.app.reference", "path trace what mane render draws with Mitsuba 3's hair BSDF (pip install mane[reference])"),
    "doctor": ("mane.app.doctor", "report the OpenGL renderer, limits, extensions and available features"),
    "simulate": ("mane.app.simulate", "simulate a groom on the GPU while the head moves; write the animation and statistics"),
    "bench": ("mane.app.bench", "run benchmarks (sim, render, oit, quality, limits, dataset, all) and print or write JSON"),
    "demo": ("mane.app.demo", "the main job: the procedural head with long wavy hair, simulated and rendered (viewer or headless clip)"),
    "dataset": ("mane.app.dataset", "make hair data sets: plan a spec, run it (locally or on Ray) into WebDataset shards, verify a set"),
    "view": ("mane.app.view", "open the interactive viewer: simulate, light and render a groom live (needs a display)"),
}


def build_parser(chosen: str | None = None) -> argparse.ArgumentParser:
    """The parser; only the ``chosen`` command's module is imported to add its arguments."""
    parser = argparse.ArgumentParser(
        prog="mane",
        description="Real-time hair simulation and rendering on the GPU.",
    )
    parser.add_argument("--version", action="version", version=f"mane {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    parser.commands = {}
    for name, (module, help_text) in COMMANDS.items():
        p = parser.commands[name] = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        if name == chosen:
            importlib.import_module(module).add_arguments(p)
    return parser


def refuse_unknown(parser: argparse.ArgumentParser, extra: list[str]) -> None:
    """argparse's error for arguments no option takes, from the command's own parser (its usage,
    ``mane CMD: error:``), with the options closest to each unknown one (``--frames``: did you
    mean --max-frames?)."""
    options = [o for a in parser._actions for o in a.option_strings]
    near = [m for e in extra if e.startswith("--")
            for m in difflib.get_close_matches(e.split("=", 1)[0], options, n=2, cutoff=0.6)]
    hint = f" (did you mean {' or '.join(dict.fromkeys(near))}?)" if near else ""
    parser.error(f"unrecognized arguments: {' '.join(extra)}{hint}")


COMPILE_BAR_COMMANDS = ("render", "simulate", "view", "demo")


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that writers clean up as for Ctrl-C."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _install_sigterm():
    """SIGTERM -> Terminated while a command runs (temporaries removed, exit 143); the old
    handler back afterwards. Only the main thread may set handlers."""
    if threading.current_thread() is not threading.main_thread():
        return None
    try:
        return signal.signal(signal.SIGTERM, _on_sigterm)
    except (ValueError, OSError):  # pragma: no cover
        return None


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    chosen = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(chosen)
    args, extra = parser.parse_known_args(argv)
    if extra:
        refuse_unknown(parser.commands.get(getattr(args, "command", None), parser), extra)
    if not getattr(args, "command", None):
        parser.print_help()
        return 0
    previous = _install_sigterm()
    from ..progress import compiles_shown
    from .options import one_line_warnings

    try:
        # a first launch's compiles on a bar in the commands that draw (the bench logs its own)
        quiet = bool(getattr(args, "quiet", False)) or args.command not in COMPILE_BAR_COMMANDS
        with one_line_warnings(args.command), compiles_shown(quiet=quiet):
            return int(importlib.import_module(args._module).run(args) or 0)
    except ManeError as exc:
        print(f"mane {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"mane {args.command}: error: out of memory; ask for less (fewer strands, guides, frames or "
              f"a smaller size)", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(f"mane {args.command}: {'terminated' if isinstance(exc, Terminated) else 'interrupted'}",
              file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    raise SystemExit(main())
