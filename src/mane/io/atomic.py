"""Write-then-rename, so that a failed write never leaves a half-written file over a good one.

Every file mane writes goes through :func:`atomic_write_path`: the writer fills a temporary
beside the target (same folder, so the rename is atomic), which is flushed to disk and renamed
over the target only when the writer finished. On any error, Ctrl-C or SIGTERM (the CLI turns
it into an exception) the temporary is removed; after a ``kill -9`` the next write to the same
target removes the dead process's temporary (its name carries the writer's process id). The
new file has the permissions a plain ``open()`` would give (``0o666 & ~umask``), or the mode of
the file it replaces; a symbolic link at the target is replaced, never written through.

:func:`check_output_path` runs the same checks before a long job starts, so a read-only
folder, a folder in the way or a name too long is a one-line error before any work.
"""
from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import tempfile
from pathlib import Path

from ..errors import ManeError

_TMP = re.compile(r"^\.(?P<stem>.*)\.mane-(?P<pid>\d+)-[^.]+\.tmp")


class OutputError(ManeError):
    """An output path that cannot be written (missing or read-only folder, a folder in the way)."""


def _umask() -> int:
    """The process umask, read without changing it (Linux), else by setting and restoring it."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


def _safe(text: str, limit: int) -> str:
    """``text`` with only portable characters (temporary names stay UTF-8 and short)."""
    return re.sub(r"[^A-Za-z0-9_+-]", "_", text)[:limit]


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def os_error(path, exc: OSError, doing: str = "cannot write") -> OutputError:
    """A one-line OutputError for ``exc`` raised while writing ``path``."""
    path = Path(path)
    if exc.errno == errno.ENAMETOOLONG:
        return OutputError(f"{path}: the file name is too long for this file system")
    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return OutputError(f"{path}: {doing} here: the folder {_folder(path)} is read-only or not yours "
                           f"({_reason(exc)})")
    if exc.errno == errno.ENOSPC:
        return OutputError(f"{path}: {doing}: no space left on the device")
    if exc.errno == errno.EISDIR:
        return OutputError(f"{path}: is a folder; give a file name")
    return OutputError(f"{path}: {doing} ({_reason(exc)})")


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def check_output_path(path, what: str = "output") -> Path:
    """Raise OutputError unless a file can be written at ``path`` now; returns ``Path(path)``.

    Checks, before any work: the path is not a folder, its folder exists and is a folder, the
    name fits the file system, and a file can really be created there (a probe temporary,
    removed at once: permissions, read-only mounts)."""
    path = Path(path)
    folder = _folder(path)
    try:
        limit = os.pathconf(folder if _is_dir(folder) else ".", "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for part in path.parts:
        if len(os.fsencode(part)) > limit:
            raise OutputError(f"{what} {path}: the name {part[:24]}... is too long ({len(os.fsencode(part))} "
                              f"bytes; this file system allows {limit})")
    if _is_dir(path):
        raise OutputError(f"{what} {path}: is a folder; give a file name")
    for parent in [folder, *folder.parents]:
        if _exists(parent) and not _is_dir(parent):
            raise OutputError(f"{what} {path}: {parent} is a file, not a folder")
    if not _is_dir(folder):
        raise OutputError(f"{what} {path}: the folder {folder} does not exist")
    try:
        fd, probe = tempfile.mkstemp(prefix=".mane-probe-", dir=folder)
    except OSError as exc:
        raise os_error(path, exc) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)
    return path


def _is_dir(p: Path) -> bool:
    try:
        return p.is_dir()
    except OSError:
        return False


def _exists(p: Path) -> bool:
    try:
        return p.exists()
    except OSError:
        return False


def _sweep(folder: Path, stem: str) -> None:
    """Remove temporaries for this target left by writers that no longer run (a kill -9)."""
    try:
        names = os.listdir(folder)
    except OSError:
        return
    for name in names:
        m = _TMP.match(name)
        if not m or m.group("stem") != stem:
            continue
        pid = int(m.group("pid"))
        if pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
            continue  # still running: its temporary, not ours to take
        except ProcessLookupError:
            pass
        except PermissionError:
            continue
        with contextlib.suppress(OSError):
            os.unlink(folder / name)


def partial_path(path) -> Path:
    """Where an interrupted streamed output is kept: ``clip.partial.mp4`` beside ``clip.mp4``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix}")


@contextlib.contextmanager
def atomic_write_path(path, *, keep_partial: bool = False):
    """Yield a temporary path in the target's directory; rename it over ``path`` on success.

    The temporary keeps the target's suffix, so libraries that choose a format by suffix
    (usd-core, trimesh) still do, and has a plain ASCII name (C++ libraries given a non-UTF-8
    target name still write). On any exception the temporary is removed and the original
    file, if any, is untouched. With ``keep_partial``, an interruption (Ctrl-C, SIGTERM) keeps
    what was written as ``partial_path(path)`` instead (streamed video frames).
    """
    path = Path(path)
    directory = _folder(path)
    if _is_dir(path):
        raise OutputError(f"{path}: is a folder; give a file name")
    if not _is_dir(directory):
        if _exists(directory) or any(_exists(p) and not _is_dir(p) for p in directory.parents):
            raise OutputError(f"{path}: a part of {directory} is a file, not a folder")
        raise OutputError(f"{path}: the folder {directory} does not exist")
    stem = _safe(path.stem, 40)
    suffix = _safe(path.suffix.lstrip("."), 16)
    suffix = f".{suffix}" if suffix else ""
    _sweep(directory, stem)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{stem}.mane-{os.getpid()}-", suffix=f".tmp{suffix}", dir=directory)
    except OSError as exc:
        raise os_error(path, exc) from None
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        mode = 0o666 & ~_umask()
        with contextlib.suppress(OSError):
            st = os.lstat(path)
            if stat.S_ISREG(st.st_mode):
                mode = stat.S_IMODE(st.st_mode)   # replacing a file keeps its permissions
        try:
            os.chmod(tmp, mode)
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, path)   # a symlink at path is replaced, not followed
        except OSError as exc:
            raise os_error(path, exc) from None
        with contextlib.suppress(OSError):
            dfd = os.open(directory, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
    except KeyboardInterrupt:
        if keep_partial and tmp.is_file() and tmp.stat().st_size > 0:
            with contextlib.suppress(OSError):
                os.chmod(tmp, 0o666 & ~_umask())
                os.replace(tmp, partial_path(path))
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
    except OSError as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise os_error(path, exc) from None
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
