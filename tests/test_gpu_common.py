"""shaders/common.glsl against NumPy twins, and legal in every shader stage."""
from __future__ import annotations

import numpy as np
import pytest

from mane.gpu.glsl import compute_shader, program

pytestmark = pytest.mark.gpu


# ------------------------------------------------------------------ NumPy twins (uint32 arithmetic wraps)

def pcg_hash_np(v):
    v = np.asarray(v, dtype=np.uint32)
    with np.errstate(over="ignore"):
        state = v * np.uint32(747796405) + np.uint32(2891336453)
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(277803737)
    return (word >> np.uint32(22)) ^ word


def hash2_np(a, b):
    return pcg_hash_np(np.asarray(a, np.uint32) ^ pcg_hash_np(b))


def rand01_np(index, seed):
    return (hash2_np(index, seed) >> np.uint32(8)).astype(np.float32) * np.float32(1.0 / 16777216.0)


KERNEL = """#version 430
#include "common.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Hashes { uint hashes[]; };
layout(std430, binding = 1) buffer Randoms { float randoms[]; };
layout(std430, binding = 2) buffer Misc { vec4 misc[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    hashes[i] = pcg_hash(i);
    randoms[i] = rand01(i, SEED);
    uint rng = rng_seed(i, SEED);
    vec3 s = unit_sphere(rng_next2(rng));
    vec3 t, b;
    orthonormal_basis(s, t, b);
    misc[i] = vec4(length(s), abs(dot(s, t)) + abs(dot(s, b)) + abs(dot(t, b)),
                   length(quat_rotate(vec4(0.0, sin(0.3), 0.0, cos(0.3)), s)),
                   length(safe_normalize(vec3(0.0), vec3(0.0, 1.0, 0.0))));
}
"""


def test_hash_and_random_match_numpy(gl, tmp_path):
    path = tmp_path / "common_test.comp"
    path.write_text(KERNEL)
    n, seed = 1024, 12345
    shader = compute_shader(gl, path, defines={"SEED": f"{seed}u"})
    bufs = [gl.buffer(reserve=n * 4), gl.buffer(reserve=n * 4), gl.buffer(reserve=n * 16)]
    for binding, buf in enumerate(bufs):
        buf.bind_to_storage_buffer(binding)
    shader.run(n // 64)
    gl.memory_barrier()
    hashes = np.frombuffer(bufs[0].read(), np.uint32)
    randoms = np.frombuffer(bufs[1].read(), np.float32)
    misc = np.frombuffer(bufs[2].read(), np.float32).reshape(n, 4)
    for buf in bufs:
        buf.release()
    index = np.arange(n, dtype=np.uint32)
    assert np.array_equal(hashes, pcg_hash_np(index))
    assert np.array_equal(randoms, rand01_np(index, seed))
    assert randoms.min() >= 0.0 and randoms.max() < 1.0 and 0.4 < randoms.mean() < 0.6
    assert np.allclose(misc[:, 0], 1.0, atol=1e-5)   # unit_sphere is on the sphere
    assert np.allclose(misc[:, 1], 0.0, atol=1e-5)   # orthonormal_basis is orthogonal
    assert np.allclose(misc[:, 2], 1.0, atol=1e-5)   # quat_rotate keeps length
    assert np.allclose(misc[:, 3], 1.0)              # safe_normalize(0) -> fallback


def test_numpy_twin_matches_python_integers():
    def pcg(v):  # the formula in plain Python ints, mod 2**32
        s = (v * 747796405 + 2891336453) % 2**32
        w = (((s >> ((s >> 28) + 4)) ^ s) * 277803737) % 2**32
        return (w >> 22) ^ w

    values = [0, 1, 12345, 2**32 - 1]
    assert [int(h) for h in pcg_hash_np(values)] == [pcg(v) for v in values]
    assert int(pcg_hash_np(0)) == 129708002


def test_common_in_every_stage(gl, tmp_path):
    use = "float use_common() { return saturate(sqr(PI) * INV_PI) + rand01(1u, 2u) + luminance(vec3(0.5)); }\n"
    stages = {
        "vertex": "#version 430\n#include \"common.glsl\"\n" + use +
                  "in vec3 p;\nvoid main() { gl_Position = vec4(p * use_common(), 1.0); }\n",
        "tess_control": "#version 430\n#include \"common.glsl\"\n" + use + "layout(vertices = 2) out;\n"
                        "void main() { gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;\n"
                        "  gl_TessLevelOuter[0] = 1.0; gl_TessLevelOuter[1] = use_common(); }\n",
        "tess_evaluation": "#version 430\n#include \"common.glsl\"\n" + use + "layout(isolines) in;\n"
                           "void main() { gl_Position = mix(gl_in[0].gl_Position, gl_in[1].gl_Position,"
                           " gl_TessCoord.x * use_common()); }\n",
        "geometry": "#version 430\n#include \"common.glsl\"\n" + use +
                    "layout(lines) in;\nlayout(line_strip, max_vertices = 2) out;\n"
                    "void main() { gl_Position = gl_in[0].gl_Position * use_common(); EmitVertex();\n"
                    "  gl_Position = gl_in[1].gl_Position; EmitVertex(); EndPrimitive(); }\n",
        "fragment": "#version 430\n#include \"common.glsl\"\n" + use +
                    "out vec4 c;\nvoid main() { c = vec4(use_common()); }\n",
    }
    paths = {}
    for stage, text in stages.items():
        paths[stage] = tmp_path / f"s_{stage}.glsl"
        paths[stage].write_text(text)
    program(gl, **paths)
