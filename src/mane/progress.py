"""Progress bars for long work (renders, simulations, conversions).

    for i in progress(range(n), desc="simulate", unit="frame", quiet=args.quiet):
        ...

A tqdm bar on stderr with a rate and a time estimate, shown only when stderr is a terminal,
``quiet`` is off and ``MANE_QUIET`` is unset, and only once the work has run ``delay``
seconds (2 by default), so quick jobs print nothing. ``stage(desc, total)`` gives a bar to
advance by hand (``bar.update(k)``) for work that is not a loop. ``compiles_shown()`` counts the
GPU programs the driver compiles while its block runs (a first launch's 3-6 s; later launches
read the driver's shader cache and print nothing).
"""
from __future__ import annotations

import os
import sys
from contextlib import contextmanager

DELAY_S = 2.0


def enabled(quiet: bool = False) -> bool:
    """Bars are shown: not quiet, MANE_QUIET unset, stderr a terminal."""
    if quiet or os.environ.get("MANE_QUIET"):
        return False
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):
        return False


def progress(iterable=None, *, total=None, desc: str = "", unit: str = "it", quiet: bool = False,
             delay: float = DELAY_S):
    """``iterable`` wrapped in a tqdm bar (returned as is when bars are off; with no iterable,
    a bar to advance by hand, or a stand-in that does nothing)."""
    if not enabled(quiet):
        return iterable if iterable is not None else _NoBar()
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit=unit, delay=delay, file=sys.stderr,
                dynamic_ncols=True, leave=False)


def stage(desc: str, total: int | None, unit: str = "step", quiet: bool = False, delay: float = DELAY_S):
    """A bar advanced by hand: ``bar = stage("convert", 3); ...; bar.update(); bar.close()``."""
    return progress(None, total=total, desc=desc, unit=unit, quiet=quiet, delay=delay)


COMPILE_DESC = "compiling GPU programs (the driver keeps them for the next launch)"


@contextmanager
def compiles_shown(quiet: bool = False, delay: float = DELAY_S):
    """A bar of the GPU programs compiled inside the block (``mane.gpu.glsl``'s "compile" phases),
    shown once the block has run ``delay`` seconds and a program is compiled after that. Yields
    the bar (None when bars are off)."""
    if not enabled(quiet):
        yield None
        return
    from . import phases

    bar = stage(COMPILE_DESC, None, unit="program", delay=delay)

    def tick(name, seconds, item):
        if name == "compile":
            bar.update(1)

    try:
        with phases.watching(tick):
            yield bar
    finally:
        bar.close()


class _NoBar:
    """What ``stage`` gives when bars are off: the same calls, doing nothing."""

    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        pass

    def close(self) -> None:
        pass
