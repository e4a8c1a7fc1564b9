"""Write-then-rename, so that a failed write never leaves a half-written file over a good one."""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ..errors import ManeError


@contextlib.contextmanager
def atomic_write_path(path):
    """Yield a temporary path in the target's directory; rename it over ``path`` on success.

    The temporary keeps the target's suffix, so libraries that choose a format by suffix
    (usd-core, trimesh) still do. On any exception the temporary is removed and the
    original file, if any, is untouched.
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise ManeError(f"{path}: the folder {directory} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=directory)
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
