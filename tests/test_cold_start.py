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


@pytest.mark.parametrize("sync", [False, True])
def test_the_cold_runs_first_frame_in_phases(gl, sync):
    """The cold-start child's phases split the simulator (groom_check, rest_data, state_upload)
    and the first frame: first_step + first_render + first_finish make first_frame, first_passes
    holds a time per renderer pass (summing to first_render), the friction grid made in the step."""
    from mane.bench import scale_bench
    from mane.render.passes.raster_segment import FORM_NAMES

    spec = dict(S=64, N=8, spg=2, size=[48, 32], steps=2, grid=8, sdf=8, render=True,
                render_settings=dict(shadows="none", msaa=1), sync_first_frame=sync)
    out = scale_bench._cold_run(spec)
    ph = out["phases"]
    # each scan-form site's state at the end (the tuner's, where it runs: GPUs)
    assert set(out["scan_forms"]) == {"hair", "dom_z0", "dom"}
    assert all(v["form"] in FORM_NAMES for v in out["scan_forms"].values())
    for name in ("groom_check", "rest_data", "state_upload", "friction_grid", "first_step", "first_render",
                 "first_passes", "first_finish", "first_frame"):
        assert name in ph, (name, sorted(ph))
    parts = ph["first_step"]["s"] + ph["first_render"]["s"] + ph["first_finish"]["s"]
    assert parts == pytest.approx(ph["first_frame"]["s"], abs=2e-3)
    from mane.render import Renderer

    r = Renderer(ctx=gl, profile=False)
    try:
        names = [p.name for p in r.passes]
    finally:
        r.release()
    assert [n for n, _ in ph["first_passes"]["items"]] == names
    assert ph["first_passes"]["s"] == pytest.approx(ph["first_render"]["s"], abs=2e-3)
    assert ph["first_step"]["n"] == ph["first_render"]["n"] == 1


def test_a_new_state_copies_its_rest_positions_on_the_gpu(gl, monkeypatch):
    """At the bind pose (the head where it was bound) the positions are the rest positions'
    bytes: a new state copies them on the GPU (no upload of positions or prev_positions); away
    from it, written from the CPU as before."""
    from mane.sim import Simulator, SimSettings
    from mane.sim.state import StateBuffer

    groom, _ = _scalp(100, 12)
    written = []
    orig = StateBuffer.write
    monkeypatch.setattr(StateBuffer, "write", lambda self, *a, **k: (written.append(id(self)), orig(self, *a, **k))[1])
    sim = Simulator(groom, (), SimSettings(), gl, points_per_strand=12)
    try:
        st = sim.state
        ids = {id(st.buffers[n]): n for n in st.buffers}
        names = {ids[i] for i in written if i in ids}
        assert "positions" not in names and "prev_positions" not in names and "rest_positions" in names
        rest = st.read("rest_positions")
        np.testing.assert_array_equal(st.read("positions"), rest)
        np.testing.assert_array_equal(st.read("prev_positions"), rest)
        assert not st.read("velocities").any() and not st.read("corrections").any()
        pts = groom.as_padded().reshape(-1, 3)
        np.testing.assert_array_equal(rest[:, :3], pts)
        # away from the bind pose: the CPU's transform, written
        m = np.eye(4)
        m[:3, 3] = (0.01, 0.02, -0.03)
        sim.set_head_transform(m)
        written.clear()
        sim.reset()
        assert {ids[i] for i in written if i in ids} >= {"positions", "prev_positions"}
        want = (pts.astype(np.float64) + m[:3, 3]).astype(np.float32)
        np.testing.assert_array_equal(st.read("positions")[:, :3], want)
    finally:
        sim.release()


def test_libegl_is_loaded_without_find_library(gl, monkeypatch):
    """The capabilities' query (the simulator's first memory check) and the GL entry points load
    libEGL.so.1 by name; ``ctypes.util.find_library`` (a subprocess: ldconfig, and where that
    misses a C compiler and the linker) only when that fails."""
    import ctypes.util

    from mane.gpu import capabilities

    asked = []
    real = ctypes.util.find_library
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: asked.append(name) or real(name))
    monkeypatch.setattr(capabilities._EGL, "_lib", None)
    monkeypatch.setattr(capabilities, "_egl_get_proc", None)
    assert capabilities._EGL.lib() is not None and capabilities._egl_proc_address() is not None
    assert asked == []
    monkeypatch.setattr(capabilities._EGL, "_lib", None)
    monkeypatch.setattr(ctypes, "CDLL", lambda name, *a, **k: (_ for _ in ()).throw(OSError(name)))
    assert capabilities._EGL.lib() is None and asked == ["EGL"]   # the fallback, asked once


def test_a_headless_context_names_its_libraries(gl, monkeypatch):
    """glcontext's EGL backend gets libGL.so.1 and libEGL.so.1 by name (no find_library: an
    ldconfig subprocess for each library at each GL version tried); its own search where they do
    not load or GLCONTEXT_LINUX_LIB* name others."""
    import ctypes
    import ctypes.util

    from mane.gpu import context

    asked = []
    real = ctypes.util.find_library
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: asked.append(name) or real(name))
    ctx = context.headless_context()
    try:
        assert ctx.version_code >= context.MIN_GL_VERSION
    finally:
        ctx.release()
        gl.__enter__()   # the shared context current again
    assert asked == []
    assert context._egl_libraries("egl") == context.EGL_LIBRARIES
    monkeypatch.setenv("GLCONTEXT_LINUX_LIBGL", "libOpenGL.so.0")
    assert context._egl_libraries("egl") == {}
    monkeypatch.delenv("GLCONTEXT_LINUX_LIBGL")
    monkeypatch.setattr(ctypes, "CDLL", lambda name, *a, **k: (_ for _ in ()).throw(OSError(name)))
    assert context._egl_libraries("egl") == {}


@pytest.mark.parametrize("chunk", [3, 2048])
def test_mean_strand_length_in_blocks_is_the_whole(monkeypatch, chunk):
    """The renderer's mean guide length (the coverage LOD's) reduced block by block is the
    one-block figure bit for bit (each guide's sum is its own; the mean over the same lengths)."""
    from mane.render import coverage_lod

    monkeypatch.setattr(coverage_lod, "LENGTH_CHUNK", chunk)
    rng = np.random.default_rng(3)
    for S in (1, 2, 3, 4, 7, 2047, 2048, 2049, 4100):
        p = rng.normal(size=(S, int(rng.integers(2, 40)), 3)).astype(np.float32)
        whole = float(np.linalg.norm(np.diff(p.astype(np.float64), axis=1), axis=-1).sum(axis=1).mean())
        assert coverage_lod.mean_strand_length(p) == whole, S
    assert coverage_lod.mean_strand_length(np.zeros((0, 5, 3), np.float32)) == 0.0
    assert coverage_lod.mean_strand_length(np.zeros((4, 1, 3), np.float32)) == 0.0
