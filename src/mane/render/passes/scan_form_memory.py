"""The scan-form tuner's decisions kept between runs (scan_form.py; mane.disk_cache, folder
``scan_form``), so that a second launch starts on the form the last one chose instead of
probing both over its first frames (on the H200 the cold start's first two frames after the
first were not steady: the probe's untimed first use of each form, the other form's programs
compiled).

A decision is kept under a key of everything it was measured on: the site, the GPU and driver
(GL_RENDERER, GL_VENDOR, GL_VERSION: NVIDIA's carries the driver's version), the settings (their
repr), the dispatch's size signature (segments, instances; exactly) and the code of the forms
(``CODE_FILES``); the decision holds the form and every form's median (the site's count). Another key is another file: nothing is recalled, the tuner probes as it
always did. A recalled decision is still checked: the chooser starts settled on it with its
medians (FormChooser.settle), times the chosen form every ``WATCH`` frames (the first watch, when
faster, scales the medians to itself) and probes again when a watched frame is ``RESCALE`` x off
the median or after ``REPROBE`` frames; the new decision
replaces the kept one. Off with the disk cache (``MANE_NO_CACHE``).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ... import disk_cache

KIND = "scan_form"
HERE = Path(__file__).resolve().parent
# the code the forms run, and the tuner's own: an edit to any of them is another key
CODE_FILES = ("scan_form.py", "raster_segment.py", "raster_segment.glsl", "hair_raster.comp", "dom_raster.comp",
              "depth_tiles.comp", "occlusion_tiles.comp", "raster_tiles.py", "raster_tiles.glsl",
              "raster_tiles_scan.comp")
_code: list = []   # the files' hash, once a process


def _code_hash() -> str:
    if not _code:
        _code.append(disk_cache.file_hash(*(HERE / name for name in CODE_FILES)))
    return _code[0]


def key(ctx, site: str, settings, sizes) -> str | None:
    """The file name of a decision at ``site`` for these settings and sizes on ``ctx``'s GPU and
    driver; None when the disk cache is off."""
    if disk_cache.root() is None:
        return None
    info = ctx.info
    gpu = tuple(str(info.get(k, "")) for k in ("GL_RENDERER", "GL_VENDOR", "GL_VERSION"))
    return disk_cache.digest(KIND, site, gpu, repr(settings), tuple(int(s) for s in sizes), _code_hash())


def recall(name: str | None, forms: int = 2) -> tuple[int, list] | None:
    """(form, [median ms of form 0, 1, ...]) kept under ``name`` for a site of ``forms`` forms,
    or None."""
    if name is None:
        return None
    got = disk_cache.load(KIND, name)
    if got is None or len(got) != 1 or got[0].shape != (1 + int(forms),):
        return None
    form, *ms = (float(v) for v in got[0])
    if form not in tuple(float(f) for f in range(forms)) or not all(math.isfinite(m) and m >= 0.0 for m in ms):
        return None
    return int(form), ms


def remember(name: str | None, form: int, medians) -> None:
    """Keep a decision under ``name`` (best effort: a read-only cache only costs the probe)."""
    if name is None or any(m is None for m in medians):
        return
    disk_cache.store(KIND, name, (np.array([float(form), *map(float, medians)], np.float64),))
