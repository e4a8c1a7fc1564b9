"""WebDataset shards and the manifest: writing (a temporary name, renamed when complete),
resuming (which shards are finished) and verifying a set.

A set is a folder of ``shard-NNNNNN.tar`` (one sample = one key with its files, in the
webdataset library's tar layout) and ``manifest.json``: the spec and its hash, the mane
version, the GPU renderer strings, and per finished shard its sample count, bytes and sha256.
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import tarfile
from pathlib import Path

from ..errors import UsageError
from .encode import expected_files
from .id_maps import ID_DTYPES
from .spec import DatasetSpec

MANIFEST = "manifest.json"
FORMAT = "mane-dataset/1"
TMP_MARK = ".tmp-"
IOV_MAX = 1024   # buffers per writev (POSIX's minimum is 16; Linux takes 1024)


def shard_name(k: int) -> str:
    return f"shard-{int(k):06d}.tar"


def sha256_file(path, chunk: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(chunk)
            if not b:
                return h.hexdigest()
            h.update(b)


class ShardFile:
    """One shard being written: samples streamed into ``.shard-N.tar.tmp-PID`` in order; ``close``
    syncs it, renames it to its name and returns (sha256, bytes). A writer that dies leaves
    only the temporary.

    The bytes are those of the webdataset library's TarWriter (USTAR members named
    ``key.ext`` in sorted order, mode 0o444, owner mane, time 0; tests check them byte for byte),
    but a sample's members are hashed and written in one call (writev): TarWriter's stream
    hands the file 10 KiB at a time, ~700 Python-level writes for a 7 MB sample, which measured
    42 ms a sample on the H200 host and bounded a GPU worker to 25 samples/s."""

    USER = GROUP = "mane"
    MODE = 0o444

    def __init__(self, out_dir, k: int):
        self.path = Path(out_dir) / shard_name(k)
        self.tmp = Path(out_dir) / f".{shard_name(k)}{TMP_MARK}{os.getpid()}"
        self._f = open(self.tmp, "wb", buffering=0)
        self._h = hashlib.sha256()
        self.size = 0
        self.samples = 0

    def _put(self, *parts) -> None:
        """Hash and append ``parts`` in one writev (no joined copy: a 4 MB sample's join was
        a memcpy holding the GIL against the renderer); hashing and writing release it."""
        views = [memoryview(b).cast("B") for b in parts if len(b)]
        for v in views:
            self._h.update(v)
        fd = self._f.fileno()
        while views:
            n = os.writev(fd, views[:IOV_MAX])
            self.size += n
            while views and n >= len(views[0]):
                n -= len(views.pop(0))
            if n:
                views[0] = views[0][n:]

    def write(self, files: dict) -> None:
        key = files["__key__"]
        parts = []
        for name in sorted(files):
            if name.startswith("_"):
                continue
            data = files[name]
            data = data.encode("utf-8") if isinstance(data, str) else data
            if not isinstance(data, (bytes, bytearray, memoryview)):
                raise ValueError(f"{name} of sample {key} is {type(data).__name__}, not bytes")
            ti = tarfile.TarInfo(f"{key}.{name}")
            ti.size, ti.mtime, ti.mode, ti.uname, ti.gname = len(data), 0, self.MODE, self.USER, self.GROUP
            parts += [ti.tobuf(tarfile.USTAR_FORMAT, "utf-8", "surrogateescape"), data,
                      bytes(-len(data) % tarfile.BLOCKSIZE)]
        self._put(*parts)
        self.samples += 1

    def close(self) -> tuple[str, int]:
        end = 2 * tarfile.BLOCKSIZE          # the end-of-archive blocks, the last record filled
        end += -(self.size + end) % tarfile.RECORDSIZE
        self._put(bytes(end))
        os.fsync(self._f.fileno())
        self._f.close()
        os.replace(self.tmp, self.path)
        return self._h.hexdigest(), self.size

    def abort(self) -> None:
        try:
            self._f.close()
        finally:
            self.tmp.unlink(missing_ok=True)


# ---------------------------------------------------------------------- manifest
def read_manifest(out_dir) -> dict | None:
    p = Path(out_dir) / MANIFEST
    if not p.exists():
        return None
    try:
        m = json.loads(p.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise UsageError(f"{p} is not a readable manifest ({exc}); move it away to start over") from None
    if m.get("format") != FORMAT:
        raise UsageError(f"{p} is not a mane data set manifest (format {m.get('format')!r})")
    return m


def write_manifest(out_dir, manifest: dict) -> None:
    from ..io.atomic import atomic_write_path

    with atomic_write_path(Path(out_dir) / MANIFEST) as tmp:
        Path(tmp).write_text(json.dumps(manifest, indent=1, sort_keys=True))


def new_manifest(spec: DatasetSpec) -> dict:
    from .. import __version__

    return {"format": FORMAT, "name": spec.name, "spec_hash": spec.hash(), "spec": spec.to_dict(),
            "mane_version": __version__, "samples": spec.samples, "samples_per_shard": spec.samples_per_shard,
            "num_shards": spec.num_shards, "outputs": list(spec.outputs), "renderers": [], "shards": {}}


def plan_resume(spec: DatasetSpec, out_dir) -> tuple[dict, list[int], dict]:
    """(manifest, shards to render, what is redone and why). Finished shards (in the manifest,
    present, of the right size and checksum) are kept; the rest, and temporaries of interrupted
    writers (removed here), are redone."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    m = read_manifest(out)
    if m is None:
        m = new_manifest(spec)
    elif m["spec_hash"] != spec.hash():
        raise UsageError(f"{out} holds another spec's data set (spec hash {m['spec_hash'][:12]}, this spec "
                         f"{spec.hash()[:12]}); choose another --out")
    redo: dict = {}
    for tmp in sorted(out.glob(f".shard-*.tar{TMP_MARK}*")):
        k = int(tmp.name[len(".shard-"):len(".shard-") + 6])
        redo[k] = "unfinished (a writer stopped mid-shard)"
        tmp.unlink()
    todo = []
    for k in range(spec.num_shards):
        name = shard_name(k)
        entry = m["shards"].get(name)
        path = out / name
        if entry is not None and path.is_file() and path.stat().st_size == entry["bytes"] \
                and sha256_file(path) == entry["sha256"]:
            continue
        if entry is not None:
            redo[k] = "checksum or size mismatch" if path.is_file() else "missing"
            del m["shards"][name]
        elif path.is_file():
            redo.setdefault(k, "not in the manifest")
        todo.append(k)
    return m, todo, {k: v for k, v in redo.items() if k in todo}


# ---------------------------------------------------------------------- verify
def verify(out_dir, decode: bool = True) -> dict:
    """Check a set: the manifest, every shard's checksum and size, its samples (count, keys in
    order, every expected file) and, with ``decode``, that every file decodes and every map's
    .npy has its dtype, shape and range (ARRAYS). Returns a report
    {"ok": bool, "shards": n, "samples": n, "problems": [...]}."""
    out = Path(out_dir)
    m = read_manifest(out)
    if m is None:
        raise UsageError(f"no {MANIFEST} in {out}: not a data set (or not started)")
    problems: list[str] = []
    files = expected_files(m["outputs"])
    samples = 0
    per = int(m["samples_per_shard"])
    for k in range(int(m["num_shards"])):
        name = shard_name(k)
        entry = m["shards"].get(name)
        path = out / name
        if entry is None:
            problems.append(f"{name}: not finished (rerun `mane dataset run` to render it)")
            continue
        if not path.is_file():
            problems.append(f"{name}: missing")
            continue
        if path.stat().st_size != entry["bytes"] or sha256_file(path) != entry["sha256"]:
            problems.append(f"{name}: checksum mismatch (truncated or changed)")
            continue
        want = list(range(k * per, min((k + 1) * per, int(m["samples"]))))
        try:
            got = _read_shard(path, files, decode, tuple(m["spec"]["size"]))
        except (tarfile.TarError, ValueError, OSError) as exc:
            problems.append(f"{name}: {exc}")
            continue
        keys = [int(key) for key in got]
        if keys != want or entry["samples"] != len(want):
            problems.append(f"{name}: samples {keys[:3]}... ({len(keys)}), expected {want[:3]}... ({len(want)})")
        samples += len(keys)
    return {"ok": not problems, "shards": len(m["shards"]), "samples": samples, "problems": problems}


def _read_shard(path: Path, files: list[str], decode: bool, size: tuple) -> dict:
    got: dict = {}
    with tarfile.open(path, "r:") as tar:
        for ti in tar:
            key, _, ext = ti.name.partition(".")
            data = tar.extractfile(ti).read()
            if decode:
                _decode(ext, data, ti.name, size)
            got.setdefault(key, set()).add(ext)
    for key, exts in got.items():
        missing = sorted(set(files) - exts)
        if missing:
            raise ValueError(f"sample {key} lacks {', '.join(missing)}")
    return got


_IDS = tuple(t.__name__ for t in ID_DTYPES)
ARRAYS = {   # a map's .npy: (dtypes, channels); ranges checked in _check_array
    "depth.npy": (("float32",), ()), "hdr.npy": (("float16",), (3,)),
    "orientation.npy": (("float16",), ()), "orientation_conf.npy": (("float16",), ()),
    "strand_id.npy": (_IDS, ()), "guide_id.npy": (_IDS, ()),
}


def _check_array(ext: str, a, size: tuple) -> None:
    """A map's dtype, shape (H, W[, C]) and range, as docs/dataset.md describes them."""
    import numpy as np

    dtypes, channels = ARRAYS[ext]
    w, h = size
    if a.dtype.name not in dtypes or a.shape != (h, w, *channels):
        raise ValueError(f"is {a.dtype.name} {a.shape}, expected {' or '.join(dtypes)} {(h, w, *channels)}")
    if ext == "orientation.npy" and not np.all((a >= 0) & (a < np.float64(np.pi))):   # not pi as float16
        raise ValueError("has angles outside [0, pi)")
    if ext in ("orientation_conf.npy", "depth.npy") and not np.all(a >= 0):
        raise ValueError("has negative or NaN values")
    if ext == "orientation_conf.npy" and not np.all(a <= 1):
        raise ValueError("has confidences above 1")


def _decode(ext: str, data: bytes, name: str, size: tuple) -> None:
    import numpy as np

    try:
        if ext.endswith(".png"):
            from PIL import Image

            Image.open(io.BytesIO(data)).load()
        elif ext.endswith(".npy"):
            a = np.load(io.BytesIO(data), allow_pickle=False)
            if ext in ARRAYS:
                _check_array(ext, a, size)
        elif ext.endswith(".npz"):
            with np.load(io.BytesIO(data), allow_pickle=False) as z:
                for k in z.files:
                    z[k]
        elif ext.endswith(".json"):
            json.loads(data)
        elif ext.endswith(".exr"):
            if data[:4] != b"\x76\x2f\x31\x01":
                raise ValueError("not an OpenEXR file")
            try:
                import OpenEXR
            except ImportError:   # the magic number is all we can check
                return
            import tempfile

            with tempfile.NamedTemporaryFile(suffix=".exr") as f:
                f.write(data)
                f.flush()
                with OpenEXR.File(f.name) as e:
                    e.channels()["RGB"].pixels
    except Exception as exc:   # any decoder's failure is a corrupt file
        raise ValueError(f"{name} does not decode ({type(exc).__name__}: {exc})") from None
