"""sdf_trilinear_diff (sdf_trilinear.glsl): the SDF's central difference from 20 texels against
MeshSDF.gradient (the NumPy twin: six trilinear samples at x +- h/2), inside the box, near its
faces (where both take the nearest point whose stencil lies in the box) and outside it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mane.gpu.glsl import compute_shader
from mane.sim import sdf as sdf_module
from mane.sim.sdf import MeshSDF

pytestmark = pytest.mark.gpu

SHADER = """#version 430
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer P { vec4 points[]; };
layout(std430, binding = 1) writeonly buffer D { vec4 diffs[]; };
uniform sampler3D tex;
uniform vec3 lo;
uniform float h;
uniform int n;
#include "sdf_trilinear.glsl"
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(n)) return;
    diffs[i] = vec4(sdf_trilinear_diff(tex, lo, h, textureSize(tex, 0), points[i].xyz), 0.0);
}
"""


@pytest.fixture(scope="module")
def field(gl):
    rng = np.random.default_rng(7)
    shape = (9, 7, 8)   # not cubic: each axis's index used in its own place
    values = rng.normal(size=shape).astype(np.float32)
    return MeshSDF(gl, values, np.array([-0.3, 0.1, 0.2]), 0.05)


def run(gl, tmp_path, sdf, pts):
    path = tmp_path / "diff.comp"
    path.write_text(SHADER)
    cs = compute_shader(gl, path, include_dirs=[Path(sdf_module.__file__).parent])
    pb = gl.buffer(np.c_[pts, np.zeros(len(pts))].astype(np.float32).tobytes())
    db = gl.buffer(reserve=len(pts) * 16)
    pb.bind_to_storage_buffer(0)
    db.bind_to_storage_buffer(1)
    sdf.texture.use(3)
    cs["tex"].value = 3
    cs["lo"].value = tuple(float(v) for v in sdf.lo)
    cs["h"].value = float(sdf.h)
    cs["n"].value = len(pts)
    cs.run((len(pts) + 63) // 64)
    out = np.frombuffer(db.read(), np.float32).reshape(-1, 4)[:, :3]
    pb.release(), db.release()
    return out


@pytest.mark.parametrize("where", ["inside", "edges", "outside"])
def test_central_difference_matches_the_twin(gl, tmp_path, field, where):
    rng = np.random.default_rng({"inside": 1, "edges": 2, "outside": 3}[where])
    if where == "inside":   # the 20-texel path, both halves of a cell on every axis
        g = rng.uniform(0.5, np.array(field.shape) - 2.0 - 1e-3, size=(400, 3))
    elif where == "edges":  # a stencil point past a face, or the +2 plane missing: clamped
        g = rng.uniform(0.0, np.array(field.shape) - 1.0, size=(400, 3))
        axis = rng.integers(0, 3, 400)
        near_top = np.array(field.shape)[axis] - rng.uniform(1.0, 2.2, 400)
        g[np.arange(400), axis] = np.where(rng.random(400) < 0.5, rng.uniform(0.0, 0.5, 400), near_top)
    else:
        g = rng.uniform(-1.5, np.array(field.shape) + 0.5, size=(400, 3))
    pts = field.lo + g * field.h
    got = run(gl, tmp_path, field, pts)
    want = field.gradient(pts) * field.h      # (v(x + e) - v(x - e)) / 2e with e = h / 2
    np.testing.assert_allclose(got, want, atol=2e-5 * np.abs(field.values).max())
    assert np.abs(want).max() > 0.5           # a field that varies: the test can fail
