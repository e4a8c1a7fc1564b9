"""Reference images on disk, keyed by a hash of everything that affects them.

    key = scene_hash(parts)              # parts: a dict of arrays, numbers and strings
    img = load(cache_dir, key)           # None when absent
    store(cache_dir, key, img, meta)

The folder is ``$MANE_REFERENCE_CACHE`` or ``~/.cache/mane/reference`` unless given; each
entry is ``<key>.npy`` (float32 H x W x C) and ``<key>.json`` (what went into it).
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

CACHE_VERSION = 1     # bump when the scene a render makes changes for the same inputs


def default_dir() -> Path:
    env = os.environ.get("MANE_REFERENCE_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "mane" / "reference"


def scene_hash(parts: dict) -> str:
    """SHA-256 (hex, first 24 characters) of ``parts`` in key order: arrays by dtype, shape
    and bytes, the rest by their JSON."""
    h = hashlib.sha256()
    h.update(f"mane-reference-{CACHE_VERSION}".encode())
    for name in sorted(parts):
        v = parts[name]
        h.update(name.encode() + b"\0")
        if isinstance(v, np.ndarray):
            a = np.ascontiguousarray(v)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(json.dumps(v, sort_keys=True, default=str).encode())
    return h.hexdigest()[:24]


def load(cache_dir, key: str) -> np.ndarray | None:
    path = Path(cache_dir) / f"{key}.npy"
    if not path.is_file():
        return None
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError):
        return None      # a torn or foreign file: render again


def store(cache_dir, key: str, image: np.ndarray, meta: dict) -> Path:
    from ..io.atomic import atomic_write_path

    d = Path(cache_dir)
    d.mkdir(parents=True, exist_ok=True)
    path = d / f"{key}.npy"
    with atomic_write_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, np.asarray(image, np.float32), allow_pickle=False)
    with atomic_write_path(d / f"{key}.json") as tmp:
        Path(tmp).write_text(json.dumps(meta, indent=1, default=str))
    return path
