"""Safe reading of untrusted files: bounds-checked binary cursors, and reading in a child process.

Every loader treats its input as hostile. The rules, enforced here once:

* sizes declared in a header are compared with the bytes that are really there *before*
  anything is allocated (``Cursor.array`` refuses a count that runs past the end);
* arrays come from ``np.frombuffer`` with explicit little-endian dtypes (``'<f4'``, ``'<u4'``);
* float data is checked for NaN and infinity, and the error names the byte offset;
* every failure is a :class:`~mane.errors.FormatError` with the path and, where it helps,
  the byte offset.

Some readers go through C++ libraries (alembic3d, usd-core) that can crash or try to allocate
terabytes on a corrupt file. :func:`read_in_child` runs such a reader in a separate Python
process with a memory and time limit; the child hands the groom back as a native ``.npz``
(read with ``allow_pickle=False``), so a crash becomes a FormatError in the parent.
"""
from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import FormatError, ManeError


def read_file_bytes(path: Path) -> bytes:
    """The whole file, with OS errors turned into FormatError."""
    try:
        return Path(path).read_bytes()
    except IsADirectoryError:
        raise FormatError("is a folder, not a file", path) from None
    except OSError as exc:
        raise FormatError(f"cannot read the file ({exc.strerror or exc})", path) from None


class Cursor:
    """A read position in a byte string; every read is checked against the end of the data."""

    def __init__(self, data: bytes, path, offset: int = 0):
        self.data = data
        self.path = path
        self.pos = offset

    @property
    def size(self) -> int:
        return len(self.data)

    @property
    def remaining(self) -> int:
        return len(self.data) - self.pos

    def error(self, message: str, offset: int | None = None) -> FormatError:
        return FormatError(message, self.path, self.pos if offset is None else offset)

    def need(self, nbytes: int, what: str, offset: int | None = None) -> None:
        """Refuse, before any allocation, a read of ``nbytes`` that runs past the end."""
        start = self.pos if offset is None else offset
        if nbytes < 0:
            raise self.error(f"{what}: negative size {nbytes}", start)
        if start < 0 or start + nbytes > len(self.data):
            raise FormatError(
                f"truncated: {what} needs {nbytes} bytes but the file has "
                f"{max(len(self.data) - start, 0)} left",
                self.path, start,
            )

    def unpack(self, fmt: str, what: str) -> tuple:
        """``struct.unpack`` at the cursor (``fmt`` must start with ``'<'``), then advance."""
        n = struct.calcsize(fmt)
        self.need(n, what)
        try:
            values = struct.unpack_from(fmt, self.data, self.pos)
        except struct.error as exc:  # cannot happen after need(), but never let it escape
            raise self.error(f"{what}: {exc}") from None
        self.pos += n
        return values

    def u32(self, what: str) -> int:
        return self.unpack("<I", what)[0]

    def i32(self, what: str) -> int:
        return self.unpack("<i", what)[0]

    def f32(self, what: str) -> float:
        return self.unpack("<f", what)[0]

    def array(self, dtype: str, count: int, what: str, offset: int | None = None,
              finite: bool = False) -> np.ndarray:
        """``count`` items of ``dtype`` at ``offset`` (default: the cursor, which then advances).

        The returned array is a read-only view of the file data.
        """
        dt = np.dtype(dtype)
        if count < 0:
            raise self.error(f"{what}: negative count {count}", offset)
        start = self.pos if offset is None else offset
        self.need(count * dt.itemsize, what, start)
        arr = np.frombuffer(self.data, dtype=dt, count=count, offset=start)
        if finite:
            check_finite(arr, what, self.path, start)
        if offset is None:
            self.pos += count * dt.itemsize
        return arr


def check_finite(arr: np.ndarray, what: str, path, base_offset: int | None = None) -> None:
    """Raise FormatError at the first NaN or infinite value (with its byte offset if known)."""
    flat = np.asarray(arr).reshape(-1)
    if flat.dtype.kind != "f":
        return
    bad = ~np.isfinite(flat)
    if bad.any():
        i = int(np.argmax(bad))
        offset = None if base_offset is None else base_offset + i * flat.dtype.itemsize
        raise FormatError(f"{what} contains a non-finite value ({flat[i]}) at item {i}", path, offset)


def check_count(count: int, what: str, path, maximum: int, offset: int | None = None) -> int:
    """A header count must be in 0..maximum (the most the file size allows)."""
    if count < 0:
        raise FormatError(f"{what} is negative ({count})", path, offset)
    if count > maximum:
        raise FormatError(
            f"{what} is {count}, more than the file's size allows ({maximum})", path, offset
        )
    return count


# ---------------------------------------------------------------------------- child process
_CHILD_ERROR_EXIT = 3
CHILD_BASE_BYTES = 3 << 30
"""Address space (RLIMIT_AS) of the reader's child, plus 64 bytes per byte of the file: usd-core
alone maps 1-2 GiB (measured), so 3 GiB leaves it ~1 GiB for a small file's data."""


def read_in_child(module: str, path: Path, options: dict, timeout: float = 300.0,
                  memory_limit: int | None = None):
    """Run ``mane.io.<module>.read_in_process(path, **options)`` in a child Python process.

    The child writes the groom to a temporary ``.npz``; a crash, a hang past ``timeout``
    seconds or an allocation past ``memory_limit`` bytes of address space become a
    FormatError here. ``options`` must be JSON-serialisable.
    """
    from . import native_npz

    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise FormatError(f"cannot read the file ({exc.strerror or exc})", path) from None
    if memory_limit is None:
        memory_limit = CHILD_BASE_BYTES + 64 * size
    src = str(Path(__file__).resolve().parents[2])  # the folder that holds the mane package
    env = dict(os.environ)
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    # address space stays near what the reader needs: few malloc arenas and worker threads
    env.setdefault("MALLOC_ARENA_MAX", "2")
    env.setdefault("PXR_WORK_THREAD_LIMIT", "2")
    with tempfile.TemporaryDirectory(prefix="mane-read-") as tmp:
        out = Path(tmp) / "groom.npz"
        source = path
        try:
            str(path).encode("utf-8")
        except UnicodeEncodeError:   # C++ readers take UTF-8 names: a link with a plain one
            source = Path(tmp) / f"input{path.suffix.encode('ascii', 'replace').decode()}"
            try:
                os.symlink(path.resolve(), source)
            except OSError as exc:
                raise FormatError(f"cannot read the file ({exc.strerror or exc})", path) from None
        cmd = [sys.executable, "-c", "from mane.io.binary import _child_main; _child_main()",
               module, str(source), json.dumps(options), str(out), str(int(memory_limit))]
        try:
            proc = subprocess.run(cmd, capture_output=True, timeout=timeout, env=env,
                                  stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            raise FormatError(f"reading took longer than {timeout:g} s; the file is probably corrupt",
                              path) from None
        if proc.returncode == _CHILD_ERROR_EXIT:
            lines = proc.stderr.decode("utf-8", "replace").strip().splitlines()
            try:
                info = json.loads(lines[-1])
                raise FormatError(str(info["message"]), path, info.get("offset"))
            except (IndexError, ValueError, KeyError, TypeError, AttributeError):
                raise FormatError(lines[-1] if lines else "cannot read", path) from None
        if proc.returncode != 0:
            how = (f"was killed by signal {-proc.returncode}" if proc.returncode < 0
                   else f"exited with status {proc.returncode}")
            tail = proc.stderr.decode("utf-8", "replace").strip().splitlines()[-1:]
            raise FormatError(
                f"the {module} reader {how} on this file; it is corrupt or hostile"
                + (f" ({tail[0][:200]})" if tail else ""), path)
        return native_npz.read(out)


def _child_main() -> None:  # pragma: no cover - runs in the child process
    import importlib

    module, path, options, out, limit = sys.argv[1:6]
    try:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (int(limit), int(limit)))
    except (ImportError, ValueError, OSError):
        pass
    try:
        mod = importlib.import_module(f"mane.io.{module}")
        groom = mod.read_in_process(Path(path), **json.loads(options))
        from . import native_npz

        native_npz.write(groom, Path(out))
    except ManeError as exc:
        msg, offset = str(exc), getattr(exc, "offset", None)
        where = getattr(exc, "path", None)
        if where is not None:
            prefix = f"{where}" + (f" (byte {offset})" if offset is not None else "") + ": "
            msg = msg[len(prefix):] if msg.startswith(prefix) else msg
        _child_fail(msg, offset)
    except MemoryError:
        _child_fail("the file asks for more memory than allowed")
    except RecursionError:
        _child_fail("the file nests too deeply")
    except Exception as exc:  # a library underneath failed on a bad file
        _child_fail(f"cannot read ({type(exc).__name__}: {str(exc)[:300]})")


def _child_fail(message: str, offset: int | None = None) -> None:  # pragma: no cover
    sys.stderr.write("\n" + json.dumps({"message": message, "offset": offset}) + "\n")
    sys.stderr.flush()
    raise SystemExit(_CHILD_ERROR_EXIT)
