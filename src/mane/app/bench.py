"""``mane bench TARGET [--json] [--out FILE] [--quick | --full]``: run a benchmark.

Targets live in ``mane.bench.targets.TARGETS`` (name -> module, help); a target module has
``run(ctx, mode, progress=None) -> dict`` (``{"meta", "results", ...}``) and
``format_text(result) -> str``. A new target is a new entry there.

Progress goes to stderr; stdout has the tables, or with ``--json`` the JSON object only.
``--out FILE`` writes the JSON there as well (whatever is printed).
"""
from __future__ import annotations

import argparse
import importlib
import inspect
import sys
from contextlib import nullcontext
from pathlib import Path

from ..bench.common import sanitise, to_json
from ..bench.targets import TARGETS
from ..errors import UsageError

HELP = "run benchmarks (sim, render, oit, quality, limits, fidelity, dataset, all) and print or write JSON"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("target", choices=sorted(TARGETS),
                        help="what to benchmark: " + "; ".join(f"{k}: {v[1]}" for k, v in TARGETS.items()))
    parser.add_argument("--json", action="store_true", help="print the results as one JSON object")
    parser.add_argument("--out", metavar="FILE", help="also write the JSON to FILE (all, quality: a folder DIR)")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="small configurations, a few steps (seconds, any GPU)")
    size.add_argument("--full", action="store_true", help="more configurations and steps (minutes)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    parser.add_argument("--driver-log", action="store_true",
                        help="record the GL driver's debug messages during the run (errors, performance warnings, "
                             "buffers NVIDIA moves to host memory) into meta.driver_log; the driver runs slower "
                             "with them on, so the run's times are not comparable")
    parser.add_argument("--section", metavar="NAMES", default=None,
                        help="sim, render, limits: only these sections, comma-separated; 'scale' (issue 14's rows: "
                             "close-ups, 100k-2M strands, a crowd, simulate + render, 1M-2M guides, cold start) "
                             "runs only when named")
    # all / quality: --out is a folder
    parser.add_argument("--only", metavar="TARGETS", help="all: only these targets, comma-separated (e.g. sim,render)")
    parser.add_argument("--baseline", metavar="DIR", help="all: another run's --out folder (e.g. --quick on a CPU) "
                                                          "whose times go beside this run's in summary.md")
    # fidelity
    parser.add_argument("--size", type=_size, default=None, help="fidelity: image WxH (default 320x320; --quick 48x48)")
    parser.add_argument("--spp", type=int, default=None, help="fidelity: reference samples per pixel (default 64)")
    parser.add_argument("--scenes", default=None, help="fidelity: scenes, comma-separated (sintel_brown, "
                                                       "sintel_blond, curly_head)")
    parser.add_argument("--models", default=None, help="fidelity: shading models, comma-separated (default all)")
    parser.add_argument("--shadows", default=None, help="fidelity: shadow methods, comma-separated (default all)")
    parser.add_argument("--grid", action="store_true", help="fidelity: every model x every shadow method")
    parser.add_argument("--rasterizer", default=None, help="fidelity: auto, hardware or compute (default auto)")
    parser.add_argument("--decompose", action="store_true",
                        help="fidelity: what the default's per-pixel error is made of (mane.bench.fidelity_decompose)")
    parser.add_argument("--split", action="store_true",
                        help="fidelity --decompose: the default frame's single and multiple scattering against the "
                             "path tracer's (a second reference at max_depth 2)")
    parser.add_argument("--cache", default=None, help="fidelity: reference image cache folder "
                                                      "(default $MANE_REFERENCE_CACHE or ~/.cache/mane/reference)")


FIDELITY_FLAGS = ("size", "spp", "scenes", "models", "shadows", "grid", "rasterizer", "decompose", "split", "cache")
ALL_FLAGS = ("only", "baseline")


def _size(text: str):
    from .render import _size as size

    return size(text)


def run(args) -> int:
    from ..gpu import get_context

    if args.target not in TARGETS:
        raise UsageError(f"unknown benchmark {args.target!r}; choose one of {', '.join(TARGETS)}")
    mode = "quick" if args.quick else "full" if args.full else "default"
    for flags, owner in ((FIDELITY_FLAGS, "fidelity"), (ALL_FLAGS, "all")):
        given = [f for f in flags if getattr(args, f, None) not in (None, False)]
        if given and args.target != owner:
            raise UsageError(f"--{given[0]} is for mane bench {owner}, not {args.target}")
    module = importlib.import_module(TARGETS[args.target][0])
    if getattr(args, "section", None) and (hasattr(module, "run_cli")
                                           or "sections" not in inspect.signature(module.run).parameters):
        raise UsageError(f"mane bench {args.target} has no sections (--section is for sim, render and limits)")
    if getattr(args, "split", False) and not getattr(args, "decompose", False):
        raise UsageError("--split is for mane bench fidelity --decompose")
    if args.target == "fidelity" and getattr(args, "decompose", False):
        module = importlib.import_module("mane.bench.fidelity_decompose")
    if hasattr(module, "run_cli"):   # all, quality: they write a folder of files
        if getattr(args, "driver_log", False):
            raise UsageError(f"--driver-log is not available for {args.target}, which writes a folder of results "
                             f"(all, quality, fidelity); use it with sim, render, oit, limits or dataset")
        return int(module.run_cli(args) or 0)
    from ..progress import enabled, progress as bar_of

    bar = None
    if args.quiet:
        progress = None
    elif enabled():   # a terminal: one bar (steps done, elapsed, rate) with the latest step's note
        bar = bar_of(total=None, desc=f"bench {args.target}", unit="step")

        def progress(msg):
            bar.set_postfix_str(msg[-60:], refresh=False)
            bar.update(1)
    else:             # a log: one line per step
        def progress(msg):
            print(f"mane bench {args.target}: {msg}", file=sys.stderr, flush=True)
    kwargs = {}
    if getattr(args, "section", None):
        kwargs["sections"] = [s.strip() for s in args.section.split(",") if s.strip()]
    ctx = get_context()
    from ..gpu.driver_log import DriverLog

    log = DriverLog(ctx) if getattr(args, "driver_log", False) else None
    try:
        with log if log is not None else nullcontext():
            result = module.run(ctx, mode, progress=progress, **kwargs)
        if log is not None and isinstance(result.get("meta"), dict):
            result["meta"]["driver_log"] = log.summary()
        result = sanitise(result)
    finally:
        if bar is not None:
            bar.close()
    text = to_json(result)
    if args.out:
        from ..io.atomic import atomic_write_path

        with atomic_write_path(args.out) as tmp:
            Path(tmp).write_text(text + "\n")
    if args.json:
        print(text)
    else:
        print(module.format_text(result))
        if log is not None:
            print("\n" + log.text())
        if args.out:
            print(f"\nJSON written to {args.out}")
    return 0
