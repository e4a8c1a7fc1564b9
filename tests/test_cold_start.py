"""The cold start's own work (issue 14): what building a Simulator and a Renderer and drawing the
first frame do besides compiling, kept to what the results need (the same images and states)."""
from __future__ import annotations

import numpy as np
import pytest


def _scalp(S=64, N=8):
    from mane.bench import sim_bench

    return sim_bench.scalp_groom(S, N), sim_bench.head_mesh()


def test_default_camera_without_points_reads_nothing_back(gl, monkeypatch):
    """``default_camera(points=None)`` frames the box alone: no read-back of the guides (a GPU
    sync and a copy of every position), and the camera is the one it was."""
    from mane.render import Renderer, RenderSettings
    from mane.render.strand_buffers import StrandBuffers

    groom, head = _scalp()
    r = Renderer(RenderSettings(size=(64, 48)), ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        with_points = r.default_camera()          # reads the guides back to fit them
        reads = []
        orig = StrandBuffers.read_positions
        monkeypatch.setattr(StrandBuffers, "read_positions", lambda self: reads.append(1) or orig(self))
        boxed = r.default_camera(points=None)
        assert reads == []
        from mane.render.camera import Camera

        lo, hi = r.framing_bbox()
        assert boxed == Camera.framing(lo, hi, azimuth=25.0, elevation=12.0, aspect=64 / 48, points=None)
        assert r.default_camera() == with_points and reads == [1]
    finally:
        r.release()
