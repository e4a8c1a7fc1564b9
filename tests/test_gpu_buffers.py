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
