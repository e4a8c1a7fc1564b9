"""GPU objects' owners: released on ``release()``, at the end of a ``with`` block, or when
dropped (a notebook cell run again gives its GPU memory back instead of leaking it)."""
from __future__ import annotations

import sys


class GpuOwner:
    """A subclass frees its GPU objects in ``release()`` and sets ``_released`` False once it
    holds any; ``release()`` guards itself with ``released_now()`` so it runs once."""

    _released = True

    def released_now(self) -> bool:
        """True the first time it is called after the owner took GPU objects, then False."""
        if self._released:
            return False
        self._released = True
        return True

    def release(self) -> None:  # pragma: no cover - every owner defines its own
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def __del__(self):
        if sys.is_finalizing() or self._released:
            return
        try:
            self.release()
        except Exception:
            pass
