"""The Python side of raster_segment.glsl (the compute rasteriser's shared scan conversion,
included by hair_raster.comp, dom_raster.comp and oit/oit_raster.comp): the defines each of
those kernels is compiled with.

TEMPORARY, for issue 14's H200 A/B of the two scan-conversion forms: ``RASTER_BALANCE`` 1 is
the load-balanced form (a work group prefix-sums its segments' sample columns in shared memory
and deals them to its threads), the default; 0 has one thread walk every column of its segment.
It is set from ``MANE_RASTER_BALANCE=0/1`` at import and read at each dispatch, so a script may
flip it between frames. The form that loses the A/B goes, and this switch with it.
"""
from __future__ import annotations

import os

from ...errors import UsageError


def _balance_from_env() -> int:
    v = os.environ.get("MANE_RASTER_BALANCE", "1").strip()
    if v not in ("0", "1"):
        raise UsageError(f"MANE_RASTER_BALANCE must be 0 or 1, not {v!r}")
    return int(v)


RASTER_BALANCE = _balance_from_env()


def raster_defines() -> dict:
    """The defines of every kernel that includes raster_segment.glsl."""
    return {"RASTER_BALANCE": int(bool(RASTER_BALANCE))}
