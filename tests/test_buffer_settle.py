"""The buffers the GPU reads heavily are read back once when made (gpu.buffers.settle_placement:
on the H200 a compute shader read a never-read-back buffer 6-17x slower)."""
import numpy as np
import pytest

from mane.gpu import buffers as gpu_buffers


@pytest.fixture
def settled(monkeypatch):
    seen = []
    real = gpu_buffers.settle_placement

    def record(buf):
        seen.append(buf)
        real(buf)

    import mane.render.strand_buffers as sb
    import mane.sim.state as state
    monkeypatch.setattr(sb, "settle_placement", record)
    monkeypatch.setattr(state, "settle_placement", record)
    return seen


def test_settle_placement_reads_the_whole_buffer(gl):
    buf = gl.buffer(np.arange(64, dtype=np.float32).tobytes())
    calls = []
    orig = type(buf).read

    class Spy(type(buf)):
        def read(self, *a, **k):
            calls.append((a, k))
            return orig(self, *a, **k)

    buf.__class__ = Spy
    gpu_buffers.settle_placement(buf)
    assert calls == [((), {})]            # one read, of everything


def test_simulator_and_renderer_settle_their_buffers(gl, settled):
    from mane import Groom
    from mane.render import Renderer, RenderSettings
    from mane.sim import Simulator
    from mane.sim.state import PARTICLE_BUFFERS

    pts = np.zeros((4, 5, 3))
    pts[..., 1] = -np.linspace(0, 0.1, 5)
    pts[:, :, 0] = np.arange(4)[:, None] * 0.01
    groom = Groom.from_strands(list(pts))
    sim = Simulator(groom, ctx=gl)
    state = sim.state
    assert all(any(b is state.buffers[n] for b in settled) for n in PARTICLE_BUFFERS)
    settled.clear()
    r = Renderer(RenderSettings(size=(32, 32)), ctx=gl)
    r.set_strands(sim)
    assert any(b is state.positions for b in settled)      # the simulator's positions, bound in place
    settled.clear()
    r.set_strands(groom)
    assert any(b is r.strands.positions for b in settled)  # a groom's uploaded positions
    r.release()
    sim.release()
