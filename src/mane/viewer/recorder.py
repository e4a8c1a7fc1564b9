"""Screenshots (PNG) and MP4 recording of what the viewer shows.

    path = save_screenshot(image, folder)          # folder/mane_YYYYmmdd_HHMMSS.png
    rec = Recorder(folder, fps=30)
    rec.add(image) ...                             # (H, W, 3) uint8, top row first
    path = rec.stop()                              # folder/mane_YYYYmmdd_HHMMSS.mp4

Frames must keep one size (the first frame's); libx264 wants even sides, so odd ones are cropped.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..errors import UsageError


def _stamp_name(folder: Path, suffix: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    base = time.strftime("mane_%Y%m%d_%H%M%S")
    path = folder / f"{base}{suffix}"
    n = 1
    while path.exists():
        path = folder / f"{base}_{n}{suffix}"
        n += 1
    return path


def save_screenshot(image: np.ndarray, folder="out/viewer", path=None) -> Path:
    """Write ``image`` ((H, W, 3 or 4) uint8) as a PNG; returns its path."""
    from PIL import Image

    path = Path(path) if path is not None else _stamp_name(Path(folder), ".png")
    path.parent.mkdir(parents=True, exist_ok=True)
    from ..io.atomic import atomic_write_path

    with atomic_write_path(path) as tmp:
        Image.fromarray(np.ascontiguousarray(image)).save(tmp, format="PNG")
    return path


class Recorder:
    """An MP4 being written (libx264 through imageio-ffmpeg), one frame per ``add``."""

    def __init__(self, folder="out/viewer", fps: float = 30.0, path=None):
        from ..io.video import mp4_writer

        if not fps > 0:
            raise UsageError(f"recording fps must be > 0, got {fps}")
        self.path = Path(path) if path is not None else _stamp_name(Path(folder), ".mp4")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fps = float(fps)
        self.frames = 0
        self.size: tuple[int, int] | None = None
        from ..io.atomic import atomic_write_path

        # frames stream into a temporary beside the file, renamed over it at stop()
        self._atomic = atomic_write_path(self.path, keep_partial=True)
        self._writer = mp4_writer(self._atomic.__enter__(), self.fps)

    @property
    def recording(self) -> bool:
        return self._writer is not None

    def add(self, image: np.ndarray) -> None:
        if self._writer is None:
            raise UsageError("the recording is stopped")
        img = np.asarray(image)[..., :3]
        h, w = img.shape[:2]
        if self.size is None:
            self.size = (w - w % 2, h - h % 2)
        w2, h2 = self.size
        if (w, h) != (w2, h2):
            if w < w2 or h < h2:   # the window shrank: pad with black
                pad = np.zeros((h2, w2, 3), np.uint8)
                pad[:min(h, h2), :min(w, w2)] = img[:h2, :w2]
                img = pad
            else:
                img = img[:h2, :w2]
        self._writer.append_data(np.ascontiguousarray(img, dtype=np.uint8))
        self.frames += 1

    def stop(self) -> Path:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
            self._atomic.__exit__(None, None, None)
        return self.path
