"""Argument ranges and work budgets of the command line, checked before any work starts.

Every numeric option is checked against the range its help documents (``number``; an option
that sets a settings field against the field's declared range, ``setting_number``), so a
negative seed, a NaN frame rate or a zero field of view is a one-line UsageError, never a
traceback deep inside NumPy. Work is bounded by budgets a user can raise:

* ``--max-frames`` (default ``MAX_FRAMES`` = 10,000): frames a ``simulate`` or ``render`` run
  may produce (``--seconds 1e9`` or ``--fps 1e9`` is refused at once, not run forever);
* ``MAX_STEPS`` (1,000,000, raised with ``--max-frames`` in proportion): simulation steps;
* ``--strand-budget`` (default ``MAX_STRANDS`` = 5,000,000): strands ``grow`` or ``render``
  (its default groom) may grow;
* host memory: a groom that would not fit in the machine's available RAM (``grow --strands``,
  ``render --guides``) is refused before it is grown (``host_memory``).
"""
from __future__ import annotations

import math

from ..errors import UsageError

MAX_FRAMES = 10_000
"""Default frame budget of ``simulate`` and ``render`` (raise it with ``--max-frames``)."""
MAX_STEPS_PER_FRAME = 100
"""Simulation steps allowed per frame of the budget (``--dt`` far below the frame time)."""
MAX_STRANDS = 5_000_000
"""Default budget of strands grown by ``grow --strands`` and ``render --guides`` (about an hour of
growing on one core; raise it with ``--strand-budget``)."""
GROW_BYTES_PER_POINT = 256
"""Peak host memory of ``grooming.grow`` per grown point (measured: ~200 bytes)."""


def number(name: str, value, *, lo=None, hi=None, lo_open: bool = False, hi_open: bool = False,
           integer: bool = False):
    """``value`` if it is a finite number in the documented range, else a UsageError saying the range."""
    rng = (f"{'(' if lo_open else '['}{'-inf' if lo is None else f'{lo:g}'}, "
           f"{'inf' if hi is None else f'{hi:g}'}{')' if hi_open else ']'}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number in {rng}, got {value!r}") from None
    bad = not math.isfinite(v)
    bad = bad or (lo is not None and (v <= lo if lo_open else v < lo))
    bad = bad or (hi is not None and (v >= hi if hi_open else v > hi))
    bad = bad or (integer and v != int(v))
    if bad:
        raise UsageError(f"{name} must be {'a whole number' if integer else 'a finite number'} in {rng}, "
                         f"got {value}")
    return value


def setting_number(flag: str, cls, name: str, value):
    """``number`` with the range a settings field declares (mane.setting): a flag that sets a
    field is checked against the field's own range, written once."""
    from dataclasses import fields

    m = next(f for f in fields(cls) if f.name == name).metadata
    number(flag, value, lo=m["lo"], hi=m["hi"], lo_open=m["lo_open"], hi_open=m["hi_open"],
           integer=m["kind"] == "int")
    if m["choices"] is not None and value not in m["choices"]:
        raise UsageError(f"{flag} must be one of {', '.join(str(c) for c in m['choices'])}, got {value}")
    return value


def frame_budget(frames: int, max_frames: int, what: str) -> int:
    """``frames`` unless beyond ``max_frames`` (UsageError naming the flag that raises it)."""
    number("--max-frames", max_frames, lo=1, integer=True)
    if frames > max_frames:
        raise UsageError(f"{what} is {frames:,} frames, more than the budget of {max_frames:,}; "
                         f"ask for fewer or raise it with --max-frames {frames}")
    return frames


def strand_budget(strands: int, budget: int | None, flag: str) -> None:
    """Refuse growing more than the strand budget (``--strand-budget`` raises it)."""
    budget = MAX_STRANDS if budget is None else budget
    number("--strand-budget", budget, lo=1, integer=True)
    if strands > budget:
        raise UsageError(f"{flag} {strands:,} is more than the budget of {budget:,} strands; ask for fewer or "
                         f"raise it with --strand-budget {strands}")


def host_memory(nbytes: float, what: str, reduce: str) -> None:
    """Refuse work whose host memory (``nbytes``) exceeds the RAM available now."""
    from ..gpu.capabilities import system_ram

    total, avail = system_ram()
    limit = avail if avail is not None else total
    if limit is not None and nbytes > limit:
        raise UsageError(f"{what} needs about {nbytes / 2**30:.1f} GiB of memory but "
                         f"{limit / 2**30:.1f} GiB is available; {reduce}")
