"""Arrays of pure functions kept on disk between runs, keyed by a hash of everything they depend on.

    key = disk_cache.digest("sdf", vertices, faces, 64, 0.02, disk_cache.file_hash(__file__))
    values, lo = disk_cache.arrays("sdf", key, lambda: bake(...))   # built once, then read

The folder is ``$XDG_CACHE_HOME/mane`` or ``~/.cache/mane`` (``root()``; the default head and the
shading table family keep their files there too); ``MANE_NO_CACHE=1`` turns the cache off (every
call builds). A file is ``ROOT/KIND/KEY.npz``; ``key`` must cover every input of the build,
its code included (``file_hash`` of the modules that compute it), so a changed input or a
changed builder reads a different file and a stale one is never used. A file that cannot be
read (truncated, damaged, not an npz, other arrays) is ignored with a warning and built again;
one that cannot be written (a read-only home) only costs the build next time.
"""
from __future__ import annotations

import hashlib
import os
import warnings
from pathlib import Path

import numpy as np


def root() -> Path | None:
    """The user cache folder of mane, or None when MANE_NO_CACHE is set."""
    if os.environ.get("MANE_NO_CACHE"):
        return None
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mane"


def file_hash(*paths) -> str:
    """sha1 of the files' bytes (the code a cached result was computed by)."""
    h = hashlib.sha1()
    for p in paths:
        h.update(Path(p).read_bytes())
    return h.hexdigest()


def digest(*parts) -> str:
    """A hex key of ``parts``: arrays by dtype, shape and bytes, anything else by repr."""
    h = hashlib.sha1()
    for p in parts:
        if isinstance(p, np.ndarray):
            a = np.ascontiguousarray(p)
            h.update(f"ndarray{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(repr(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:24]


def path(kind: str, key: str) -> Path | None:
    base = root()
    return None if base is None else base / kind / f"{key}.npz"


def load(kind: str, key: str) -> tuple[np.ndarray, ...] | None:
    """The arrays stored under ``ROOT/kind/key.npz``, or None (absent, cache off, or unreadable:
    then with a warning)."""
    file = path(kind, key)
    if file is None or not file.is_file():
        return None
    try:
        with np.load(file, allow_pickle=False) as z:
            n = int(z["count"])
            return tuple(z[f"a{i}"] for i in range(n))
    except Exception as exc:  # noqa: BLE001  any damage at all: build again
        warnings.warn(f"mane: ignoring the unreadable cache file {file} ({type(exc).__name__}: {exc}); "
                      "building it again", RuntimeWarning, stacklevel=3)
        return None


def store(kind: str, key: str, out: tuple) -> None:
    """Keep ``out`` (a tuple of arrays) under ``ROOT/kind/key.npz``; best effort, atomic (a
    temporary file renamed over: readers never see half a file)."""
    file = path(kind, key)
    if file is None:
        return
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        tmp = file.with_name(f".{file.stem}.{os.getpid()}.tmp.npz")
        np.savez(tmp, count=np.array(len(out)), **{f"a{i}": a for i, a in enumerate(out)})
        os.replace(tmp, file)
    except OSError:
        pass


def arrays(kind: str, key: str, build) -> tuple[np.ndarray, ...]:
    """``build()``'s tuple of arrays, read from ``ROOT/kind/key.npz`` when it is there, else
    built and stored."""
    out = load(kind, key)
    if out is None:
        out = tuple(np.asarray(a) for a in build())
        store(kind, key, out)
    return out
