"""std430 structs (NumPy dtype and GLSL text from one definition) and the GPU memory guard."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import GPUMemoryError, UsageError
from mane.gpu import buffers as bufmod
from mane.gpu import capabilities as capmod
from mane.gpu.buffers import Struct, buffer, check_allocation, std430_array_stride

# ------------------------------------------------------------------ layouts, hand-computed


@pytest.mark.parametrize("fields, offsets, size, align", [
    ([("a", "vec3"), ("b", "float")], [0, 12], 16, 16),             # a float packs after a vec3
    ([("a", "float"), ("b", "vec3")], [0, 16], 32, 16),             # a vec3 is aligned to 16
    ([("a", "float"), ("b", "vec2"), ("c", "float")], [0, 8, 16], 24, 8),
    ([("w", "float", 4)], [0], 16, 4),                              # scalar arrays: stride 4
    ([("a", "int"), ("v", "vec3", 2), ("c", "float")], [0, 16, 48], 64, 16),  # vec3[]: stride 16
    ([("m", "mat4"), ("p", "vec3")], [0, 64], 80, 16),
    ([("a", "uint"), ("m", "mat3")], [0, 16], 64, 16),              # mat3: 3 columns of 16
    ([("a", "float"), ("m", "mat2")], [0, 8], 24, 8),               # mat2: 2 columns of 8
    ([("a", "float"), ("i", "ivec4"), ("u", "uvec2")], [0, 16, 32], 48, 16),
    ([("a", "float"), ("b", "float"), ("c", "float")], [0, 4, 8], 12, 4),  # no rounding to 16
])
def test_std430_offsets(fields, offsets, size, align):
    s = Struct("S", fields)
    assert list(s.offsets.values()) == offsets
    assert s.size == size and s.alignment == align
    assert s.dtype.itemsize == size
    assert [s.dtype.fields[f[0]][1] for f in fields] == offsets


def test_nested_struct_and_struct_arrays():
    inner = Struct("Inner", [("a", "vec2"), ("b", "float")])       # 12 bytes -> 16, aligned to 8
    assert (inner.size, inner.alignment) == (16, 8)
    outer = Struct("Outer", [("x", "float"), ("i", inner), ("y", "float"), ("arr", inner, 3), ("z", "float")])
    assert outer.offsets == {"x": 0, "i": 8, "y": 24, "arr": 32, "z": 80}
    assert (outer.size, outer.alignment) == (88, 8)
    text = outer.glsl()
    assert text.index("struct Inner {") < text.index("struct Outer {")
    assert "    Inner arr[3];" in text


def test_array_strides():
    assert [std430_array_stride(t) for t in ("float", "vec2", "vec3", "vec4", "mat3", "mat4")] == \
        [4, 8, 16, 16, 48, 64]


def test_numpy_shapes():
    s = Struct("P", [("p", "vec3"), ("m", "mat4"), ("n", "mat3"), ("v", "vec3", 2), ("f", "float", 3), ("k", "int")])
    a = s.zeros(5)
    assert a.shape == (5,) and a.dtype.itemsize == s.size
    assert a["p"].shape == (5, 3) and a["m"].shape == (5, 4, 4) and a["n"].shape == (5, 3, 4)
    assert a["v"].shape == (5, 2, 4) and a["f"].shape == (5, 3) and a["k"].shape == (5,)


def test_glsl_text():
    s = Struct("Particle", [("position", "vec3"), ("mass", "float"), ("weights", "float", 4)])
    text = s.glsl()
    assert text.startswith("struct Particle {\n    vec3 position;")
    assert "    float weights[4];" in text and "};" in text
    block = s.block("Particles", "particles", 2, qualifier="readonly")
    assert block == "layout(std430, binding = 2) readonly buffer Particles { Particle particles[]; };\n"


@pytest.mark.parametrize("fields", [
    [], [("a", "double")], [("a", "float"), ("a", "int")], [("1a", "float")], [("a", "float", 0)], [("a",)],
    [("in", "float")], [("gl_Position", "vec4")], [("vec3", "float")],
])
def test_bad_structs(fields):
    with pytest.raises(UsageError):
        Struct("S", fields)


# ------------------------------------------------------------------ the shader agrees


@pytest.mark.gpu
def test_shader_and_numpy_agree(gl):
    inner = Struct("Inner", [("a", "vec2"), ("b", "float")])
    s = Struct("Thing", [("f", "float"), ("p", "vec3"), ("q", "float"), ("i", "ivec4"), ("w", "float", 3),
                         ("v", "vec3", 2), ("m", "mat4"), ("n", "mat3"), ("u", "uint"), ("inner", inner), ("k", "vec2")])
    source = ("#version 430\nlayout(local_size_x = 1) in;\n" + s.glsl() + s.block("Things", "things", 0) + """
void main() {
    uint e = gl_GlobalInvocationID.x;
    float b = float(e) * 1000.0;
    Thing t;
    t.f = b + 1.0; t.p = vec3(b + 2.0, b + 3.0, b + 4.0); t.q = b + 5.0;
    t.i = ivec4(6, 7, 8, int(e)); t.w[0] = b + 9.0; t.w[1] = b + 10.0; t.w[2] = b + 11.0;
    t.v[0] = vec3(12.0, 13.0, 14.0); t.v[1] = vec3(15.0, 16.0, b + 17.0);
    t.m = mat4(0.0); t.m[1][2] = b + 18.0;           // column 1, row 2
    t.n = mat3(0.0); t.n[2] = vec3(19.0, 20.0, 21.0);
    t.u = 22u + e; t.inner.a = vec2(23.0, 24.0); t.inner.b = 25.0; t.k = vec2(26.0, b + 27.0);
    things[e] = t;
}
""")
    shader = gl.compute_shader(source)
    n = 3
    buf = gl.buffer(np.full(n * s.size, 0xFF, np.uint8).tobytes())
    buf.bind_to_storage_buffer(0)
    shader.run(n)
    gl.memory_barrier()
    a = np.frombuffer(buf.read(), dtype=s.dtype)
    shader.release()
    buf.release()
    for e in range(n):
        b = e * 1000.0
        t = a[e]
        assert t["f"] == b + 1 and list(t["p"]) == [b + 2, b + 3, b + 4] and t["q"] == b + 5
        assert list(t["i"]) == [6, 7, 8, e] and list(t["w"]) == [b + 9, b + 10, b + 11]
        assert list(t["v"][0, :3]) == [12, 13, 14] and list(t["v"][1, :3]) == [15, 16, b + 17]
        assert t["m"][1, 2] == b + 18 and np.count_nonzero(t["m"]) == (1 if b + 18 else 0)
        assert list(t["n"][2, :3]) == [19, 20, 21]
        assert t["u"] == 22 + e and list(t["inner"]["a"]) == [23, 24] and t["inner"]["b"] == 25
        assert list(t["k"]) == [26, b + 27]


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
