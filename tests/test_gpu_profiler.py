"""GpuProfiler: sections, nesting, both sources, the query pool, reset and the summary."""
from __future__ import annotations

import time

import numpy as np
import pytest

from mane.errors import UsageError
from mane.gpu.capabilities import get_capabilities
from mane.gpu.profiler import EVERY, GpuProfiler, profile_every

pytestmark = pytest.mark.gpu

BUSY = """#version 430
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer B { float v[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    float x = v[i];
    for (int k = 0; k < ITERATIONS; k++) x = sin(x) * 1.0001 + 0.1;
    v[i] = x;
}
"""


@pytest.fixture(scope="module")
def work(gl):
    """A compute dispatch that takes a few milliseconds on llvmpipe."""
    shader = gl.compute_shader(BUSY.replace("ITERATIONS", "200"))
    buf = gl.buffer(np.zeros(4096, np.float32).tobytes())

    def run():
        buf.bind_to_storage_buffer(0)
        shader.run(4096 // 64)

    yield run
    shader.release()
    buf.release()


def test_source_is_cpu_on_software_renderers(gl):
    prof = GpuProfiler(gl)
    if get_capabilities(gl).is_software:
        assert prof.source == "cpu" and "software renderer" in prof.reason
    else:
        assert prof.source == "gpu-timer"


@pytest.mark.parametrize("source", ["cpu", "gpu-timer"])
def test_a_compute_dispatch_is_timed(gl, work, source):
    prof = GpuProfiler(gl, source=source, every=1)
    assert prof.source == source
    for _ in range(3):
        with prof.section("simulate"):
            work()
        prof.frame()
    means = prof.means(wait=True)
    assert set(means) == {"simulate"} and means["simulate"] > 0
    assert len(prof.samples("simulate")) == 3
    assert prof.frames == 3 and prof.frame_ms() > 0


@pytest.mark.parametrize("source", ["cpu", "gpu-timer"])
def test_sections_nest(gl, work, source):
    prof = GpuProfiler(gl, source=source, every=1)
    for _ in range(2):
        with prof.section("render"):
            work()
            with prof.section("shading"):
                work()
        prof.frame()
    means = prof.means(wait=True)
    assert set(means) == {"render", "shading"}
    assert means["render"] >= means["shading"] > 0
    table = prof.summary()
    assert "render" in table and "\n    shading" in table  # nested section indented


def test_reopening_an_open_section_is_a_clear_error(gl):
    prof = GpuProfiler(gl, source="cpu")
    with prof.section("outer"):
        with pytest.raises(UsageError, match="'outer' is already open"):
            with prof.section("outer"):
                pass
    with prof.section("outer"):  # the stack recovered
        pass
    assert len(prof.samples("outer")) == 2


def test_reset_and_disabled(gl, work):
    prof = GpuProfiler(gl, source="gpu-timer")
    with prof.section("a"):
        work()
    prof.frame()
    prof.reset()
    assert prof.means(wait=True) == {} and prof.frames == 0 and prof.samples("a") == []
    off = GpuProfiler(gl, enabled=False)
    with off.section("a"):
        work()
    assert off.means() == {} and "no samples" in off.summary()


def test_gpu_results_are_polled_not_waited_for(gl, work, monkeypatch):
    """While the GPU is behind, sections queue up to pool_size query pairs per name, no more."""
    prof = GpuProfiler(gl, source="gpu-timer", pool_size=2)
    monkeypatch.setattr(prof._queries, "available", lambda q: False)  # the GPU never catches up
    for _ in range(6):
        with prof.section("pass"):
            pass
    pending = sum(1 for n, _ in prof._pending if n == "pass")
    assert pending == 2  # pool_size in flight; older ones were waited for to reuse their queries
    assert len(prof.samples("pass")) == 4
    assert len(prof._free.get("pass", [])) + pending <= 3  # no query objects leak
    prof.flush()
    assert len(prof.samples("pass")) == 6


@pytest.mark.parametrize("source", ["cpu", "gpu-timer"])
def test_every_nth_frame_is_timed(gl, work, source):
    """``every`` N: the sections of frames 0, N, 2N... are timed, the others cost nothing; by
    default one frame in four."""
    assert GpuProfiler(gl, source=source).every == EVERY == 4
    prof = GpuProfiler(gl, source=source, every=3)
    for _ in range(7):
        with prof.section("simulate"):
            work()
        prof.frame()
    assert len(prof.samples("simulate", wait=True)) == 3   # frames 0, 3 and 6
    assert prof.frames == 7 and len(prof._frame_ms) == 6    # the wall time of every frame
    for bad in (0, -2, 1.5, "4", True):
        with pytest.raises(UsageError, match="every"):
            GpuProfiler(gl, source=source, every=bad)


def test_one_availability_query_a_frame_while_the_gpu_is_behind(gl, work, monkeypatch):
    """Sections end in the order their closing stamps were issued, and the GPU writes stamps in
    that order: the first result not ready ends the look (each query can flush the driver's
    command buffer on the CPU's issue of the frame)."""
    prof = GpuProfiler(gl, source="gpu-timer")
    asked = []

    def never(q):
        asked.append(q)
        return False

    monkeypatch.setattr(prof._queries, "available", never)
    for name in ("a", "b", "c", "d", "e"):
        with prof.section(name):
            work()
    assert asked == []            # sections do not poll
    prof.frame()
    assert len(asked) == 1        # the frame asks once, for the oldest section
    monkeypatch.undo()
    prof.flush()
    assert [len(prof.samples(n)) for n in "abcde"] == [1] * 5


def test_profile_arguments(gl):
    """Renderer's and Simulator's ``profile``: False off, True the source's default, N every Nth."""
    assert [profile_every(p) for p in (False, True, 0, 1, 8)] == [0, None, 0, 1, 8]
    for bad in (-1, 2.5, "yes", None):
        with pytest.raises(UsageError, match="profile must be"):
            profile_every(bad)


def test_summary_is_a_table(gl):
    prof = GpuProfiler(gl, source="cpu")
    with prof.section("simulate"):
        pass
    with prof.section("a much longer name"):
        pass
    lines = prof.summary().splitlines()
    assert lines[0].startswith("GPU timings (cpu")
    header, rows = lines[1], lines[2:]
    assert "mean ms" in header
    assert len({len(r) for r in rows}) == 1  # aligned


def test_bad_source(gl):
    with pytest.raises(UsageError):
        GpuProfiler(gl, source="sundial")


def test_llvmpipe_timer_queries_are_unreliable(gl):
    """Why the profiler falls back to the CPU on software renderers (re-check on Mesa upgrades)."""
    if "llvmpipe" not in gl.info["GL_RENDERER"]:
        pytest.skip("llvmpipe only")
    shader = gl.compute_shader(BUSY.replace("ITERATIONS", "400"))
    buf = gl.buffer(reserve=4 * 4096)
    buf.bind_to_storage_buffer(0)
    query = gl.query(time=True)
    t0 = time.perf_counter()
    with query:
        shader.run(4096 // 64)
    gl.finish()
    cpu_ns = (time.perf_counter() - t0) * 1e9
    elapsed = query.elapsed
    shader.release()
    buf.release()
    if 0.1 * cpu_ns < elapsed < 10 * cpu_ns:
        pytest.skip(f"llvmpipe's GL_TIME_ELAPSED looks right now ({elapsed} ns vs {cpu_ns:.0f} ns on the CPU): "
                    "the CPU fallback for software renderers may no longer be needed")
    assert elapsed < 0.1 * cpu_ns


def test_renderer_and_simulator_time_every_nth_frame(gl):
    """``Renderer(profile=N)`` times the passes of every Nth frame, ``Simulator(profile=N)`` every
    Nth step's; the rest issue no queries (and drain nothing)."""
    from mane.render import Renderer, RenderSettings
    from mane.sim import Simulator
    from tests.test_oit_methods import BASE, CAM, LIGHTS, curtain_groom

    groom = curtain_groom(n=8, points=6)
    sim = Simulator(groom, [], ctx=gl, profile=2)
    r = Renderer(RenderSettings(**BASE), ctx=gl, profile=3)
    try:
        r.set_strands(sim)
        for _ in range(5):
            sim.step()
        for _ in range(7):
            r.render(CAM, LIGHTS)
        assert r.profiler.every == 3 and r.profiler.frames == 7
        assert {len(r.profiler.samples(n, wait=True)) for n in r.profiler.names()} == {3}   # frames 0, 3, 6
        assert sim._profiler.every == 2 and sim._profiler.frames == 5
        assert {len(sim._profiler.samples(n, wait=True)) for n in sim._profiler.names()} == {3}   # steps 0, 2, 4
        with pytest.raises(UsageError, match="profile must be"):
            Renderer(RenderSettings(**BASE), ctx=gl, profile=-1)
    finally:
        r.release()
        sim.release()
