"""Frames issued from a recording of their GL calls (mane.gpu.replay, mane.render.frame_replay):
a played frame is the frame the passes would have drawn, bit for bit, also while the hair
moves; anything a frame is made of that changes makes it drawn again; frames that read
something back are never played; per-frame counters (the scan-form tuner, the tiled raster's
peak check) count played frames as drawn ones. The test suite runs with VERIFY on (conftest):
every frame that would have been played is drawn and compared with its recording."""
from __future__ import annotations

from dataclasses import replace

import moderngl
import numpy as np
import pytest

from mane.gpu import replay as gl_replay
from mane.gpu.capabilities import get_capabilities
from mane.render import Renderer, frame_replay, light_key
from mane.render.passes import raster_tiles
from mane.render.passes.scan_form import FormChooser

from test_render_frame_cache import CAM, CAM2, LIGHTS, LIGHTS2, ball, base_settings, fan

PHASES = 2   # shadow_lights 3 of the three lights: two extra lights, one's maps drawn a frame in turn

# ---------------------------------------------------------------------------- the recorder
def test_a_recording_issues_the_same_calls_again(gl):
    buf = gl.buffer(reserve=64)
    tex = gl.texture((4, 4), 4)
    data = bytearray(b"\x01" * 16)
    floats = np.arange(4, dtype=np.float32)
    with gl_replay.record() as rec:
        buf.bind_to_storage_buffer(np.int64(3))   # a NumPy number stays a number
        tex.use(2)
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        buf.write(data, offset=16)
        buf.write(floats, offset=32)
        gl.memory_barrier()
    data[:] = b"\x02" * 16          # the recording keeps the data as they were written
    floats[:] = 9.0
    assert rec.side is None
    names = [c.func.__qualname__ for c in rec.calls]
    assert names == ["Buffer.bind_to_storage_buffer", "Texture.use", "Texture.filter", "Buffer.write", "Buffer.write",
                     "Context.memory_barrier"]
    assert rec.calls[0].args[1] == 3 and rec.calls[3].args[1] == b"\x01" * 16 and rec.calls[3].keywords == {"offset": 16}
    buf.write(bytes(64))
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    rec.play()
    assert buf.read()[16:32] == b"\x01" * 16
    assert np.array_equal(np.frombuffer(buf.read()[32:48], np.float32), [0, 1, 2, 3])
    assert tex.filter == (moderngl.NEAREST, moderngl.NEAREST)
    # moderngl's classes are themselves again outside the block
    assert all(cls.__dict__[name] is original for cls, name, original, _ in gl_replay._table())
    with gl_replay.record() as other:
        buf.bind_to_storage_buffer(3)
    assert rec.difference(other) is not None and other.difference(other) is None
    buf.release()
    tex.release()


def test_pruned_drops_only_binds_of_what_is_bound_already(gl):
    buf, other = gl.buffer(reserve=64), gl.buffer(reserve=64)
    tex = gl.texture((4, 4), 4)
    fbo = gl.framebuffer([tex])
    cs = gl.compute_shader("#version 430\nlayout(local_size_x = 1) in;\nvoid main() {}\n")
    with gl_replay.record() as rec:
        fbo.use()
        buf.bind_to_storage_buffer(3)
        tex.use(2)
        cs.run(1)
        buf.bind_to_storage_buffer(3)        # dropped: point 3 holds it
        other.bind_to_storage_buffer(4)
        tex.use(2)                           # dropped: unit 2 holds it
        fbo.use()                            # dropped
        gl.memory_barrier()
        buf.bind_to_storage_buffer(3, offset=16)   # kept: another range
        tex.write(bytes(64))                 # moderngl binds tex to a unit of its own for this
        tex.use(2)                           # kept: what is known of the units is forgotten
        fbo.use()                            # kept
        other.bind_to_storage_buffer(4)      # dropped: a write changes no storage binding
    names = [c.func.__qualname__ for c in rec.pruned().calls]
    assert names == ["Framebuffer.use", "Buffer.bind_to_storage_buffer", "Texture.use", "ComputeShader.run",
                     "Buffer.bind_to_storage_buffer", "Context.memory_barrier", "Buffer.bind_to_storage_buffer",
                     "Texture.write", "Texture.use", "Framebuffer.use"]
    for o in (cs, fbo, tex, buf, other):
        o.release()


def test_reads_queries_fences_and_new_objects_make_a_recording_side(gl):
    from mane.gpu.fence import Fence

    buf = gl.buffer(reserve=16)
    for act, why in ((lambda: buf.read(), "Buffer.read"), (lambda: gl.buffer(reserve=4).release(), "Context.buffer"),
                     (lambda: Fence().wait(), "a fence")):
        with gl_replay.record() as rec:
            buf.bind_to_storage_buffer(0)
            act()
        assert rec.side == why
    buf.release()


def test_hooks_and_nested_recording(gl):
    with gl_replay.record() as rec:
        gl_replay.each_frame(lambda: True, lambda: None)
        with pytest.raises(RuntimeError):
            gl_replay.record().__enter__()
    assert len(rec.hooks) == 1 and rec.ready()
    gl_replay.each_frame(lambda: False, lambda: None)   # no recording: nothing kept anywhere
    assert gl_replay._active is None


# ---------------------------------------------------------------------------- the renderer
@pytest.fixture
def playing(gl, monkeypatch):
    """A renderer of the small scene that plays its recordings (VERIFY off), released after."""
    monkeypatch.setattr(frame_replay, "VERIFY", False)
    r = _renderer(gl)
    yield r
    r.release()


def _renderer(gl, **kw):
    r = Renderer(base_settings(**{"shadow_lights": 3, **kw}), ctx=gl, profile=False)
    r.set_strands(fan())
    r.set_head(ball())
    return r


def _until_played(r, camera=CAM, lights=LIGHTS, limit=400):   # (a GPU's tuner times its forms first)
    for _ in range(limit):
        before = r.stats()["frames_replayed"]
        r.render(camera, lights)
        if r.stats()["frames_replayed"] > before:
            return
    takes = {k: (t.confirmed, [ready.__qualname__ for ready, _ in t.rec.hooks if not ready()])
             for k, t in r._replay.takes.items()}
    raise AssertionError(f"no frame played in {limit}: recordings (confirmed, hooks not quiet) {takes}, "
                         f"tuner {r.scan_forms.details()}")


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer, msaa", [("compute", 1), ("hardware", 1), ("hardware", 4)])
def test_played_frames_equal_drawn_frames_while_the_hair_moves(gl, rasterizer, msaa, monkeypatch):
    """Two renderers of one scene, one playing its recordings, the other drawing every frame;
    between frames the strands' positions are written (a simulation's step)."""
    monkeypatch.setattr(frame_replay, "VERIFY", False)
    played, drawn = (_renderer(gl, rasterizer=rasterizer, msaa=msaa) for _ in range(2))
    try:
        drawn._replay = _NeverReplay(drawn)
        _until_played(played)
        for _ in range(played.frames_rendered):
            drawn.render(CAM, LIGHTS)
        rest = np.frombuffer(played.strands.positions.read(), np.float32).reshape(-1, 4).copy()
        before = played.stats()["frames_replayed"]
        exact = get_capabilities(gl).is_software   # a GPU's float atomics add in another order each frame
        for step in range(200):   # (on GPUs the scan-form tuner's probe first times its forms: frames drawn)
            moved = rest.copy()
            moved[:, 0] += 0.0002 * (step + 1)   # the strands slide sideways, a frame at a time
            for r in (played, drawn):
                r.strands.positions.write(moved.tobytes())
                r.strands_changed()
            a = played.render_image(CAM, LIGHTS)
            b = drawn.render_image(CAM, LIGHTS)
            differ = np.any(a != b, axis=2)
            if exact:
                assert not differ.any(), f"step {step}: {np.count_nonzero(differ)} pixels differ"
            else:
                assert np.abs(a.astype(int) - b).max() <= 1 and differ.mean() < 0.01, f"step {step}"
            if step >= 3 * PHASES and played.stats()["frames_replayed"] >= before + 2 * PHASES:
                break
        assert played.stats()["frames_replayed"] >= before + 2 * PHASES, "the moving hair's frames were not played"
        assert drawn.stats()["frames_replayed"] == 0
        assert not np.array_equal(a, first_image(rest, played)), "the hair did not move in the picture"
    finally:
        played.release()
        drawn.release()


def first_image(rest, r) -> np.ndarray:
    r.strands.positions.write(rest.tobytes())
    r.strands_changed()
    return r.render_image(CAM, LIGHTS)


class _NeverReplay(frame_replay.FrameReplay):
    def plan(self, camera, lights, refine):
        return "draw", None


@pytest.mark.gpu
def test_each_turn_of_the_extra_lights_has_its_recording(playing, monkeypatch):
    monkeypatch.setattr(light_key, "KEEP", False)   # the lights' maps drawn every frame, as when the hair moves
    _until_played(playing)
    _until_played(playing)
    takes = playing._replay.takes
    assert sorted(takes) == list(range(PHASES)) and all(t.confirmed for t in takes.values())
    assert takes[0].rec.difference(takes[1].rec) is not None   # another light's maps drawn


@pytest.mark.gpu
def test_whatever_changes_draws_the_next_frame(playing, monkeypatch):
    r = playing
    changes = [
        ("camera", lambda: None, CAM2, LIGHTS),
        ("lights", lambda: None, CAM, LIGHTS2),
        ("settings", lambda: setattr(r, "settings", replace(r.settings, exposure=1.3)), CAM, LIGHTS),
        ("head", lambda: r.set_head(ball(0.08)), CAM, LIGHTS),
        ("strands", lambda: r.set_strands(fan(0.01)), CAM, LIGHTS),
        ("a module switch", lambda: monkeypatch.setattr(light_key, "KEEP", not light_key.KEEP), CAM, LIGHTS),
    ]
    for name, change, camera, lights in changes:
        _until_played(r)
        change()
        before = r.stats()["frames_replayed"]
        r.render(camera, lights)
        assert r.stats()["frames_replayed"] == before, f"the frame after a new {name} was played"
        try:
            _until_played(r, camera, lights)   # and the new scene's frames are played in turn
        except AssertionError as exc:
            raise AssertionError(f"after a new {name}: {exc}") from None
        _until_played(r)


@pytest.mark.gpu
def test_a_key_that_changes_every_frame_records_nothing(playing):
    """A head that moves every frame (the bench's nodding loop): every frame drawn, none recorded
    (a recording costs more than a drawn frame); once it stops, its frames are played."""
    for i in range(6):
        m = np.eye(4)
        m[1, 3] = 0.001 * i
        playing.set_head_transform(m)
        playing.render(CAM, LIGHTS)
        assert not playing._replay.takes
    _until_played(playing)


@pytest.mark.gpu
def test_a_camera_of_numpy_vectors_is_played_and_moved(playing):
    from mane.render import Camera

    def cam(x):
        return Camera(eye=np.array([x, 0.05, 0.8]), target=np.zeros(3), fov_y=32.0, near=0.1, far=3.0)

    _until_played(playing, cam(0.0))
    before = playing.stats()["frames_replayed"]
    playing.render(cam(0.01), LIGHTS)
    assert playing.stats()["frames_replayed"] == before


@pytest.mark.gpu
def test_verify_finds_a_frame_that_depends_on_something_outside_the_key(gl, monkeypatch):
    """A pass that starts making another call while nothing in the key changed (here: patched
    to): VERIFY draws the frame a recording would have stood in for and sees the difference."""
    monkeypatch.setattr(frame_replay, "VERIFY", True)
    r = _renderer(gl)
    try:
        for _ in range(3 * PHASES):
            r.render(CAM, LIGHTS)
        resolve = r.get_pass("resolve")
        run = resolve.run

        def run_and_more(frame):
            run(frame)
            gl.memory_barrier()

        monkeypatch.setattr(resolve, "run", run_and_more)
        with pytest.raises(frame_replay.ReplayMismatch, match="Context.memory_barrier"):
            for _ in range(PHASES):
                r.render(CAM, LIGHTS)
    finally:
        r.release()


@pytest.mark.gpu
def test_frames_with_profiler_sections_or_refining_are_drawn(gl, monkeypatch):
    monkeypatch.setattr(frame_replay, "VERIFY", False)
    r = Renderer(base_settings(), ctx=gl, profile=1)   # every frame timed
    try:
        r.set_strands(fan())
        r.set_head(ball())
        for _ in range(3 * PHASES):
            r.render(CAM, LIGHTS)
            r.render(CAM, LIGHTS, refine=True)
        assert r.stats()["frames_replayed"] == 0
        r.profiler.enabled = False
        _until_played(r)
    finally:
        r.release()


# ---------------------------------------------------------------------------- per-frame counters
def test_a_settled_choosers_timed_frames_come_where_they_would_with_frames_played():
    """A chooser asked every frame, and one skipped on every frame quiet_next calls quiet (a
    played frame), time the same frames and probe again at the same frame."""
    a, b = FormChooser(0, watch=7, reprobe=40), FormChooser(0, watch=7, reprobe=40)
    key, sizes = "k", (1000, 1)
    timed_a, timed_b, skipped = [], [], 0
    for frame in range(200):
        fa, ta = a.next(key, sizes)
        if ta is not None:
            timed_a.append(frame)
            a.record(ta, 1.0 + 0.01 * ta[1])
        if b.quiet_next():
            b.skip()
            skipped += 1
            continue
        fb, tb = b.next(key, sizes)
        assert fb == fa
        if tb is not None:
            timed_b.append(frame)
            b.record(tb, 1.0 + 0.01 * tb[1])
    assert timed_a == timed_b and len(timed_a) > 20
    assert skipped > 60   # most settled frames are quiet: played, not asked


def test_the_tiled_rasters_peak_check_keeps_its_cadence(gl):
    """Frames played between drawn ones count as steps: the peak is still copied every
    CHECK_EVERY steps."""
    t = raster_tiles.RasterTiles(gl)
    copies, skipped = [], 0
    try:
        for step in range(1, 3 * raster_tiles.CHECK_EVERY + 1):
            if t.index is not None and t._quiet_next():
                t._skip()
                skipped += 1
                continue
            pending = t._pending
            t.prepare((64, 64), 100)
            if t._pending is not None and t._pending is not pending:
                copies.append(t._steps)
            gl.finish()
        assert copies and all(s % raster_tiles.CHECK_EVERY == 0 for s in copies)
        assert len(copies) == 3 if raster_tiles.CAPACITY is None else not copies
        assert skipped > raster_tiles.CHECK_EVERY   # most steps were played ones
    finally:
        t.release()
