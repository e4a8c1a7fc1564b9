"""A material's lookup tables from a family over absorption, for materials that change often.

The Chiang azimuthal table and the dual-scattering table of a material are built per colour
channel: channel c of the table (``[..., c]``, c < 3) depends on that channel's absorption
sigma_a[c] alone (and on eta, beta_n, roughness... shared by the channels), and column 3 on none
of them (the R lobe). Building one exactly costs ~0.06 s of NumPy for Chiang's fibre (1-2 s
for Marschner's dual tables), which a data set whose melanin is drawn per sample would pay every
sample. ``tables="interpolated"`` builds instead,
once per process (and on disk), the tables at a fixed grid of absorptions, GRID_SIZE values
spaced evenly in log(sigma_a + SIGMA_0) over [0, SIGMA_MAX], and gives a material's channel by
interpolating log(table) (a signed or zero texel: the table itself) linearly in
log(sigma_a + SIGMA_0) between its two grid neighbours (a table is a sum of exp(-sigma_a x path)
terms: nearly linear in that form). Error against the
exact table: tests/test_shading_table_family.py (within 2% where a texel is above 1e-3 of the
table's peak, 0.5% of the peak anywhere; the dual table's signed backscatter shift within 0.1
degree). The grid costs ~1-2 s of NumPy for Chiang's fibre (~20 s for Marschner's) the first
time on a machine (a few grid values per new material until the grid fills), then is read from the disk cache (mane.disk_cache: ~/.cache/mane/tables).
"""
from __future__ import annotations

import hashlib
from collections import OrderedDict
from pathlib import Path

import numpy as np

from ... import disk_cache

SIGMA_0 = 0.05
SIGMA_MAX = 40.0     # per unit radius; eumelanin 8 + pheomelanin 1.5 gives 12.6 in blue
GRID_SIZE = 64
GRID = np.exp(np.linspace(np.log(SIGMA_0), np.log(SIGMA_MAX + SIGMA_0), GRID_SIZE)) - SIGMA_0
GRID[0] = 0.0
_U_GRID = np.log(GRID + SIGMA_0)   # the grid in the interpolation's coordinate

_memory: "OrderedDict[tuple, np.ndarray]" = OrderedDict()
_MEMORY_ENTRIES = 4 * GRID_SIZE


def _code_hash() -> str:
    """The tables' builders as they are now (chiang.py, dual_scattering.py and the Marschner
    lobes of luts.py that the dual tables use): a change to any makes new files instead of
    reading stale ones."""
    here = Path(__file__).parent
    return disk_cache.file_hash(*(here / name for name in ("chiang.py", "dual_scattering.py", "luts.py")))


CODE = _code_hash()


def _key(kind: str, rest: tuple, i: int) -> str:
    """Grid value i's file name in the disk cache (``mane.disk_cache``, folder ``tables``)."""
    h = hashlib.sha1(repr((kind, rest, GRID_SIZE, SIGMA_0, SIGMA_MAX, CODE)).encode()).hexdigest()[:16]
    return f"{kind}-{h}-{i:03d}"


def _grid_tables(kind: str, rest: tuple, needed: list[int], build) -> None:
    """Fill the memory cache with grid values ``needed`` (from disk, or built three at a time:
    ``build(sigma_a (3,))`` gives a (..., 4) table whose channel c belongs to sigma_a[c])."""
    todo = []
    for i in needed:
        key = (kind, rest, i)
        if key in _memory:
            _memory.move_to_end(key)
            continue
        stored = disk_cache.load("tables", _key(kind, rest, i))   # None: absent, damaged or cache off
        if stored is not None:
            _memory[key] = stored[0]
        else:
            todo.append(i)
    for j in range(0, len(todo), 3):
        idx = todo[j:j + 3]
        sig = np.array([GRID[k] for k in idx] + [GRID[idx[-1]]] * (3 - len(idx)))
        table = np.asarray(build(sig), np.float32)
        for c, i in enumerate(idx):
            one = np.stack([table[..., c], table[..., 3]], axis=-1)   # its channel, the colourless column
            _memory[(kind, rest, i)] = one
            disk_cache.store("tables", _key(kind, rest, i), (one,))
    while len(_memory) > _MEMORY_ENTRIES:
        _memory.popitem(last=False)


def bracket(sigma: float) -> tuple[int, float]:
    """(k, w): sigma lies between GRID[k] and GRID[k + 1], at weight w of the way in
    log(sigma + SIGMA_0)."""
    if not np.isfinite(sigma) or sigma < 0:
        raise ValueError(f"absorption must be finite and >= 0, got {sigma}")
    u = np.log(min(float(sigma), SIGMA_MAX) + SIGMA_0)
    k = int(np.clip(np.searchsorted(_U_GRID, u) - 1, 0, GRID_SIZE - 2))
    return k, float(np.clip((u - _U_GRID[k]) / (_U_GRID[k + 1] - _U_GRID[k]), 0.0, 1.0))


def interpolated(kind: str, rest: tuple, sigma_a, build) -> np.ndarray:
    """The (..., 4) table of absorption ``sigma_a`` (3,) from the family ``kind`` (its other
    parameters ``rest``, hashable), built by ``build(sigma_a (3,))`` at grid values as needed."""
    sigma_a = np.asarray(sigma_a, np.float64).reshape(3)
    brackets = [bracket(s) for s in sigma_a]
    _grid_tables(kind, rest, sorted({k + d for k, _ in brackets for d in (0, 1)}), build)
    first = _memory[(kind, rest, brackets[0][0])]
    out = np.empty(first.shape[:-1] + (4,), np.float32)
    for c, (k, w) in enumerate(brackets):
        a = _memory[(kind, rest, k)][..., 0].astype(np.float64)
        b = _memory[(kind, rest, k + 1)][..., 0].astype(np.float64)
        positive = (a > 0) & (b > 0)   # geometric where both are positive (exp-like), else linear
        geo = np.exp((1.0 - w) * np.log(np.where(positive, a, 1.0)) + w * np.log(np.where(positive, b, 1.0)))
        out[..., c] = np.where(positive, geo, (1.0 - w) * a + w * b)
    out[..., 3] = first[..., 1]
    return out
