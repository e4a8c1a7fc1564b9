"""The frames pass: the guides' transported frames rebuilt from the current positions."""
from __future__ import annotations

from .base import Frame, Pass


class FramesPass(Pass):
    """Rebuild the guides' transported frames from the current positions (compute)."""

    name = "frames"
    reads = ("strands",)
    writes = ("frames",)

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.strands is not None and self.renderer.frames_dirty

    def run(self, frame: Frame) -> None:
        self.renderer.rebuild_frames()
