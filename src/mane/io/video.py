"""MP4 (H.264) writing through imageio's ffmpeg plugin (imageio-ffmpeg, a mane dependency).

    writer = mp4_writer("turntable.mp4", fps=30)
    writer.append_data(rgb_uint8)       # (H, W, 3), H and W even
    writer.close()

The plugin is asked for by name: without imageio-ffmpeg imageio would otherwise hand a .mp4
to whichever plugin accepts the file (its TIFF writer, failing later on ``fps``); this raises
a ManeError that says what to install instead.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import ManeError


def require_ffmpeg() -> None:
    """Raise ManeError unless imageio and its ffmpeg backend (imageio-ffmpeg) import."""
    try:
        import imageio  # noqa: F401
        import imageio_ffmpeg  # noqa: F401
    except ImportError as exc:
        raise ManeError(f"writing MP4 video needs imageio-ffmpeg ({exc}); pip install imageio-ffmpeg "
                        "(a mane dependency), or write PNG frames instead") from None


def mp4_writer(path, fps: float, *, quality: int = 8):
    """An imageio ffmpeg writer for ``path`` (libx264, ``quality`` 0-10, no macro-block
    resizing: frame sizes must be even)."""
    require_ffmpeg()
    import imageio.v2 as imageio

    return imageio.get_writer(str(Path(path)), format="FFMPEG", mode="I", fps=float(fps), codec="libx264",
                              quality=quality, macro_block_size=1, ffmpeg_log_level="error")
