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


@pytest.mark.parametrize("case", ["scalp", "float64"])
def test_groom_bbox_is_the_rows_reduction(case):
    """Groom.bbox reduces component by component (fast) and gives what the row-wise reduction
    gave, bit for bit."""
    from mane.groom import Groom

    groom, _ = _scalp(500, 16)
    pts = groom.points if case == "scalp" else groom.points.astype(np.float64)
    g = Groom(pts, groom.counts)
    for got, ref in zip(g.bbox(), (g.points.min(axis=0), g.points.max(axis=0))):
        assert got.dtype == ref.dtype and got.shape == (3,)
        assert got.tobytes() == ref.tobytes()


def test_groom_bbox_keeps_the_rows_signed_zero():
    """A box side at zero, with 0.0 and -0.0 among the points: which one the min gives depends on
    the order it meets them in, and the component-wise order can differ from the rows' (it does
    in some of these patterns): bbox gives the rows' answer."""
    from mane.groom import Groom

    groom, _ = _scalp(40, 8)
    rng = np.random.default_rng(1)
    differed = 0
    for _ in range(60):
        pts = groom.points.copy()
        pts[:, 0] = np.abs(pts[:, 0]) + 0.5       # the x side at zero: the zeros below
        pts[:, 2] = -np.abs(pts[:, 2]) - 0.5      # the z side's max at zero
        zero = rng.random(len(pts)) < rng.random()
        neg = rng.random(len(pts)) < 0.5
        pts[zero, 0] = np.where(neg[zero], -0.0, 0.0)
        pts[zero, 2] = np.where(neg[zero], -0.0, 0.0)
        g = Groom(pts, groom.counts)
        rows = (pts.min(axis=0), pts.max(axis=0))
        t = np.ascontiguousarray(pts.T)
        differed += (t.min(axis=1).tobytes(), t.max(axis=1).tobytes()) != (rows[0].tobytes(), rows[1].tobytes())
        lo, hi = g.bbox()
        assert lo.tobytes() == rows[0].tobytes() and hi.tobytes() == rows[1].tobytes()
    assert differed   # the test would catch the component-wise order alone
