"""The Python side of raster_segment.glsl (the compute rasteriser's shared scan conversion,
included by hair_raster.comp, dom_raster.comp and oit/oit_raster.comp): the defines each of
those kernels is compiled with.

``RASTER_BALANCE`` picks the form: 1, the load-balanced one (a work group prefix-sums its
segments' sample columns in shared memory and deals them to its threads): on the H200 it took
the 100k-strand close-up's scan conversion from 23.4 to 8.6 ms and 1M strands' from 11.8 to 7.0
(docs/performance.md), but the crowd of 100 small heads is faster in the other (10.22 against
14.28 ms a frame); 0, one thread walking every column of its segment, on CPU rasterisers
(llvmpipe runs a work group as SIMD loops: no warp imbalance to win back, and the barriers and
searches made the scan 3-4x slower there). Both visit the same samples with the same values
(tests/test_render_compute_balance.py), so the form may change from frame to frame.

2, the tiled form (hair_raster.comp only; raster_tiles.py): the segments binned to screen tiles
and each tile's samples visited in shared memory, the same buffers again.

``balance_for`` is the fixed rule (balanced unless a CPU rasteriser). On GPUs the hair raster and
the deep opacity raster take their form from the renderer's tuner instead (scan_form.py: each
site times its forms and keeps the fastest), and pass it to ``raster_defines``; the OIT fill and
the shadow map's hair depths keep the fixed rule. ``MANE_RASTER_BALANCE=0/1/2`` (or a name of
FORM_NAMES) forces a form everywhere, the tuner off (read at import); a script may also set
``FORCED`` between frames (scan_form.TUNE = False keeps the fixed rule without forcing). A site
without the forced form (the tiled one everywhere but the hair raster) takes the balanced one.
"""
from __future__ import annotations

import os

from ...errors import UsageError
from ...gpu.capabilities import get_capabilities   # cached per context


FORM_NAMES = ("per_thread", "balanced", "tiled")   # RASTER_BALANCE 0, 1, 2
TILED = 2


def _balance_from_env() -> int | None:
    v = os.environ.get("MANE_RASTER_BALANCE", "").strip()
    if v == "":
        return None
    if v in FORM_NAMES:
        return FORM_NAMES.index(v)
    if v not in ("0", "1", "2"):
        raise UsageError(f"MANE_RASTER_BALANCE must be 0, 1, 2 or one of {', '.join(FORM_NAMES)}, not {v!r}")
    return int(v)


FORCED = _balance_from_env()   # None: by the renderer (balance_for)


def form_for(ctx, forms: int = 2) -> int:
    """The fixed rule's form at a site with forms 0..``forms`` - 1: FORCED when set (the balanced
    form where the site lacks it), else 1 unless a CPU rasteriser."""
    if FORCED is not None:
        f = int(FORCED)
        return f if 0 <= f < forms else 1
    return 0 if get_capabilities(ctx).is_software else 1


def balance_for(ctx) -> int:
    """The scan-conversion form for ``ctx``'s GPU at a site of the two forms 0 and 1 (form_for)."""
    return form_for(ctx, 2)


SUBGROUP_SCAN = None     # column scans by subgroup operations: None where subgroup_scan(ctx) says


def subgroup_scan(ctx) -> bool:
    """Whether the balanced form's and the tiled walk's column scans use subgroup operations
    (RASTER_SUBGROUP, RT_SUBGROUP): compute shaders with GL_KHR_shader_subgroup's basic and
    arithmetic features, subgroups of a power of two of at least 8 invocations (NVIDIA: 32;
    llvmpipe has none)."""
    if SUBGROUP_SCAN is not None:
        return bool(SUBGROUP_SCAN)
    sub = get_capabilities(ctx).subgroup
    size, stages, features = (sub.get(k) or 0 for k in ("size", "stages", "features"))
    return size >= 8 and size & (size - 1) == 0 and bool(stages & 0x20) and features & 0x5 == 0x5


def subgroup_defines(ctx, form: int) -> dict:
    """RASTER_SUBGROUP for a kernel that includes raster_segment.glsl in ``form`` and declares
    the subgroup extension under it (hair_raster.comp, dom_raster.comp)."""
    return {"RASTER_SUBGROUP": int(form == 1 and subgroup_scan(ctx))}


def raster_defines(ctx, balance: int | None = None) -> dict:
    """The defines of every kernel that includes raster_segment.glsl: ``balance`` the form (a
    site's tuner's, scan_form.py; the tiled form 2 where the caller has it), None the fixed rule
    (balance_for)."""
    form = balance_for(ctx) if balance is None else int(balance)
    if form not in (0, 1, TILED):
        raise ValueError(f"no scan-conversion form {balance!r}")
    return {"RASTER_BALANCE": form}
