"""Wall-clock phases of a start-up (issue 14's cold start): where the seconds before the first
steady frame go.

    with phases.recording() as rec:          # the cold-start bench's child
        ...build a Simulator and a Renderer, draw frames...
    rec.as_dict()   # {"sdf_bake": {"s": 0.41, "n": 1}, "compile": {"s": 0.9, "n": 37, "items": [...]}, ...}

    with phases.phase("sdf_bake"):           # in the code that does the work
        ...
    with phases.phase("compile", "hair_raster.comp"):   # ``items``: (what, seconds) each time
        ...
    phases.add("pass", 0.004, "hair")        # seconds the caller measured itself
    with phases.watching(lambda name, s, item: ...):   # told of each phase as it ends
        ...

A phase adds its seconds and one count to every recording open at the time; with none open it
costs one list check. Phases nest (a program compiled during the first frame counts in both
``compile`` and the caller's phase): a recording's sums are per name, not a partition.
"""
from __future__ import annotations

import time
from contextlib import contextmanager

_open: list["Recording"] = []


class Recording:
    """Seconds and counts per phase name, in the order the names were first seen."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.counts: dict[str, int] = {}
        self.items: dict[str, list] = {}

    def add(self, name: str, seconds: float, item: str | None = None) -> None:
        self.seconds[name] = self.seconds.get(name, 0.0) + float(seconds)
        self.counts[name] = self.counts.get(name, 0) + 1
        if item is not None:
            self.items.setdefault(name, []).append([item, round(float(seconds), 6)])

    def as_dict(self) -> dict:
        out = {k: {"s": round(v, 6), "n": self.counts[k]} for k, v in self.seconds.items()}
        for k, v in self.items.items():
            out[k]["items"] = list(v)
        return out


@contextmanager
def phase(name: str, item: str | None = None):
    """Time the block as phase ``name`` in every open recording (nothing when none is open);
    ``item`` names this occurrence (kept with its seconds)."""
    if not _open:
        yield
        return
    t = time.perf_counter()
    try:
        yield
    finally:
        dt = time.perf_counter() - t
        for rec in _open:
            rec.add(name, dt, item)


def add(name: str, seconds: float, item: str | None = None) -> None:
    """Seconds measured by the caller (between two callbacks, say) as phase ``name`` in every open
    recording; ``item`` as ``phase``'s."""
    for rec in _open:
        rec.add(name, seconds, item)


@contextmanager
def recording():
    """Collect the phases run inside the block into a Recording."""
    rec = Recording()
    _open.append(rec)
    try:
        yield rec
    finally:
        _open.remove(rec)


class _Watcher(Recording):
    def __init__(self, fn) -> None:
        super().__init__()
        self.fn = fn

    def add(self, name: str, seconds: float, item: str | None = None) -> None:
        self.fn(name, float(seconds), item)


@contextmanager
def watching(fn):
    """Call ``fn(name, seconds, item)`` for each phase that ends inside the block (``add`` too)."""
    w = _Watcher(fn)
    _open.append(w)
    try:
        yield w
    finally:
        _open.remove(w)
