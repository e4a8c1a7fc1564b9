"""The GPU memory guard: allocations checked against the budget before anything is allocated."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import GPUMemoryError, UsageError
from mane.gpu import buffers as bufmod
from mane.gpu import capabilities as capmod
from mane.gpu.buffers import buffer, check_allocation

# ------------------------------------------------------------------ the memory guard


@pytest.mark.gpu
def test_absurd_size_is_refused_before_allocating(gl, monkeypatch):
    def must_not_allocate(*args, **kwargs):
        raise AssertionError("ctx.buffer was called")

    monkeypatch.setattr(gl, "buffer", must_not_allocate)
    nbytes = 1 << 50  # 1 PiB
    with pytest.raises(GPUMemoryError) as info:
        check_allocation(gl, nbytes, "strand positions")
    assert "strand positions" in str(info.value) and "1024.0 TiB" in str(info.value)
    with pytest.raises(GPUMemoryError, match="strand positions"):
        buffer(gl, nbytes, what="strand positions")
    with pytest.raises(GPUMemoryError, match="free"):
        check_allocation(gl, nbytes, "vertices", ssbo=False)  # past the SSBO check: memory


@pytest.mark.gpu
def test_ssbo_limit(gl):
    limit = capmod.get_capabilities(gl).limits["max_shader_storage_block_size"]
    with pytest.raises(GPUMemoryError, match="GL_MAX_SHADER_STORAGE_BLOCK_SIZE"):
        check_allocation(gl, limit + 4, "positions")
    check_allocation(gl, limit, "positions")
    check_allocation(gl, limit + 4, "a vertex buffer", ssbo=False)


@pytest.mark.gpu
def test_reported_memory_is_checked(gl, monkeypatch):
    monkeypatch.setattr(capmod, "gpu_memory",
                        lambda *a, **k: capmod.GPUMemory(8 << 30, 1000, "GL_NVX_gpu_memory_info"))
    check_allocation(gl, 1000, "small")
    with pytest.raises(GPUMemoryError) as info:
        check_allocation(gl, 1001, "guide strands")
    assert "guide strands" in str(info.value) and "GL_NVX_gpu_memory_info" in str(info.value)


@pytest.mark.gpu
def test_buffer_helper(gl):
    data = np.arange(16, dtype=np.float32)
    buf = buffer(gl, data, what="test data")
    assert np.array_equal(np.frombuffer(buf.read(), np.float32), data)
    buf.release()
    buf = buffer(gl, 64, what="scratch")
    assert buf.size == 64
    buf.release()
    with pytest.raises(UsageError):
        buffer(gl, 0, what="nothing")
    with pytest.raises(UsageError):
        check_allocation(gl, -1, "negative")


@pytest.mark.gpu
def test_driver_out_of_memory_becomes_gpu_memory_error(gl, monkeypatch):
    monkeypatch.setattr(bufmod, "_gl_error", lambda ctx: "GL_OUT_OF_MEMORY")
    with pytest.raises(GPUMemoryError, match="GL_OUT_OF_MEMORY"):
        buffer(gl, 64, what="scratch")


# ------------------------------------------------------------------ read-back through a GPU copy


@pytest.mark.gpu
@pytest.mark.parametrize("staging", [bufmod.STAGING_BYTES, 64, 100])
def test_device_buffer_reads_what_a_mapped_read_reads(gl, monkeypatch, staging):
    """DeviceBuffer.read / read_into / clear against moderngl's own (mapped) read of a plain
    twin, whole and in pieces, with staging pieces smaller than the read (64, 100 bytes)."""
    monkeypatch.setattr(bufmod, "STAGING_BYTES", staging)
    data = np.random.default_rng(1).integers(0, 256, 1000, dtype=np.uint8).tobytes()
    plain = gl.buffer(data)
    dev = bufmod.as_device(gl.buffer(data))
    try:
        assert isinstance(dev, bufmod.DeviceBuffer) and bufmod.as_device(dev) is dev
        assert dev.read() == plain.read() == data
        for size, offset in [(-1, 0), (1, 0), (999, 1), (300, 700), (-1, 357), (128, 64)]:
            assert dev.read(size, offset) == plain.read(size, offset) == (
                data[offset:] if size < 0 else data[offset:offset + size]), (size, offset)
        assert dev.read(0, 1000) == dev.read(-1, 1000) == b""   # (moderngl's mapped read refuses these)
        out = bytearray(1010)
        dev.read_into(out, 400, 250, write_offset=7)
        assert out[7:407] == data[250:650] and out[:7] == bytes(7) and out[407:] == bytes(603)
        dev.clear(200, 100)
        expect = data[:100] + bytes(200) + data[300:]
        assert dev.read() == expect
        dev.clear(chunk=b"\x01\x02\x03\x04", size=400, offset=600)
        assert dev.read() == expect[:600] + b"\x01\x02\x03\x04" * 100
        dev.clear()
        assert dev.read() == bytes(1000)
    finally:
        plain.release()
        dev.release()


@pytest.mark.gpu
def test_device_buffer_refuses_reads_outside_it(gl):
    dev = bufmod.as_device(gl.buffer(bytes(64)))
    try:
        for size, offset in [(65, 0), (1, 64), (-1, 65), (8, -1)]:
            with pytest.raises(UsageError, match="64-byte buffer"):
                dev.read(size, offset)
        with pytest.raises(UsageError, match="64-byte buffer"):
            dev.clear(8, 60)
        with pytest.raises(UsageError, match="does not divide"):
            dev.clear(chunk=b"abc")
    finally:
        dev.release()


@pytest.mark.gpu
def test_the_gpu_working_buffers_are_never_mapped(gl, monkeypatch):
    """The simulator's state and the renderer's guides, frames, expanded strands and per-sample
    buffers are read back (framing, bounds, stats, snapshots, tests) and cleared only through a
    GPU copy or a write: a mapped read or write of one makes NVIDIA's driver move it to host
    memory for good (its debug output: "copied/moved from VIDEO memory to DMA CACHED memory")."""
    import moderngl

    from mane.render import Renderer, RenderSettings
    from mane.sim.settings import SimSettings
    from mane.sim.simulator import Simulator
    from tests.test_render_strands import bent_groom

    mapped = set()
    for name in ("read", "read_into", "clear"):
        base = getattr(moderngl.Buffer, name)

        def spy(self, *args, _base=base, **kwargs):
            mapped.add(self.glo)
            return _base(self, *args, **kwargs)

        monkeypatch.setattr(moderngl.Buffer, name, spy)
    sim = Simulator(bent_groom(guides=6, points=8), settings=SimSettings(grid_resolution=16), ctx=gl)
    r = Renderer(RenderSettings(size=(64, 48), msaa=1, strands_per_guide=4, rasterizer="compute"), ctx=gl,
                 profile=False)
    try:
        r.set_strands(sim)
        cam = r.default_camera()
        for _ in range(2):
            sim.step()
            r.strands_changed()
            r.render(cam)
        sim.snapshot()
        sim.reset()
        r.strands.bbox(refresh=True)
        r.stats()
        working = {b.glo for b in sim.state.buffers.values()}
        working |= {r.strands.positions.glo, r.strands.frames.glo, r.get_pass("expand").buffer.glo}
        working |= {b.glo for _, b in r.get_pass("hair_compute")._buffers}
        assert mapped, "the spy saw no read at all: the test would pass for nothing"
        assert not (mapped & working)
    finally:
        r.release()
        sim.release()


@pytest.mark.gpu
def test_checked_buffers_are_device_buffers_unless_read_every_frame(gl):
    dev, ring = buffer(gl, 64, "a working buffer"), buffer(gl, 64, "a counter read a frame late", host_read=True)
    try:
        assert isinstance(dev, bufmod.DeviceBuffer)
        assert not isinstance(ring, bufmod.DeviceBuffer)   # its direct read waits for no later frame
    finally:
        dev.release()
        ring.release()
