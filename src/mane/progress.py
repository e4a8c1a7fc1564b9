"""Progress bars for long work (renders, simulations, conversions).

    for i in progress(range(n), desc="simulate", unit="frame", quiet=args.quiet):
        ...

A tqdm bar on stderr with a rate and a time estimate, shown only when stderr is a terminal,
``quiet`` is off and ``MANE_QUIET`` is unset, and only once the work has run ``delay``
seconds (2 by default), so quick jobs print nothing. ``stage(desc, total)`` gives a bar to
advance by hand (``bar.update(k)``) for work that is not a loop.
"""
from __future__ import annotations

import os
import sys

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


def stage(desc: str, total: int, unit: str = "step", quiet: bool = False, delay: float = DELAY_S):
    """A bar advanced by hand: ``bar = stage("convert", 3); ...; bar.update(); bar.close()``."""
    return progress(None, total=total, desc=desc, unit=unit, quiet=quiet, delay=delay)


class _NoBar:
    """What ``stage`` gives when bars are off: the same calls, doing nothing."""

    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        pass

    def close(self) -> None:
        pass
