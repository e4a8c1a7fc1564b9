"""A still picture's frames on the raster units resolved to a box filter (passes/sample_resolve.py)."""
from __future__ import annotations

import moderngl
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from mane.render import Renderer, RenderSettings
from mane.render.passes import sample_resolve
from mane.render.passes.accumulate import still_jitter
from test_render_tessellation import wavy_groom

unit = st.floats(0.0, 1.0, exclude_max=True)
half = st.floats(-0.5, 0.5, exclude_max=True)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(unit, unit), min_size=1, max_size=16), half, half)
def test_each_sample_is_fetched_from_the_pixel_it_fell_in(positions, dx, dy):
    # sample i of pixel q sees the unmoved image at q + s_i - d; pixel p takes it from
    # q = p + offset_i: that point must lie in [p, p + 1)
    s = np.array(positions)
    seen = sample_resolve.offsets(s, (dx, dy)) + (s - np.array([dx, dy]))
    assert np.all(seen >= 0.0) and np.all(seen <= 1.0)   # (1.0: s - d rounded up to 0)


def test_the_twin_takes_each_sample_from_its_offset_pixel():
    rng = np.random.default_rng(0)
    samples = rng.random((5, 7, 4, 3))
    offsets = np.array([[0, 0], [1, 0], [0, -1], [-1, 1]])
    got = sample_resolve.resolve_numpy(samples, offsets)
    y, x = 2, 3
    want = (samples[2, 3, 0] + samples[2, 4, 1] + samples[1, 3, 2] + samples[3, 2, 3]) / 4
    assert np.allclose(got[y, x], want)
    assert np.allclose(got[0, 0], (samples[0, 0, 0] + samples[0, 1, 1] + samples[0, 0, 2] + samples[1, 0, 3]) / 4)


def _renderer(gl, **kw):
    s = RenderSettings(**{"size": (96, 72), "strands_per_guide": 4, "shadows": "none", "draw_head": False,
                          "rasterizer": "hardware", **kw})
    r = Renderer(s, ctx=gl, profile=False)
    r.set_strands(wavy_groom(guides=6, points=8))
    return r


@pytest.mark.parametrize("samples", [2, 4, 8])
def test_the_gpus_sample_positions_are_read_back(gl, samples):
    r = _renderer(gl, msaa=samples)
    try:
        if r.samples != samples:
            pytest.skip(f"the GPU gives {r.samples} samples for {samples}")
        s = sample_resolve.sample_positions(r)
        assert s.shape == (samples, 2) and np.all((s >= 0.0) & (s < 1.0))
        assert len({tuple(p) for p in s}) == samples                  # distinct
        assert sample_resolve.sample_positions(r) is s                # read once
    finally:
        r.release()


_WRITE_POSITION = """#version 430
uniform vec2 u_jitter;
out vec4 frag;
void main() { frag = vec4(gl_FragCoord.xy - u_jitter, float(gl_SampleID), 1.0); }   // per sample
"""


def test_the_resolve_takes_the_points_of_the_pixel_and_matches_its_twin(gl):
    # every sample writes the unmoved image's point it sees (its window position minus the
    # jitter): resolved, each pixel's samples saw points inside it, a quarter of a pixel apart or
    # more, and the GPU's resolve is the twin's
    r = _renderer(gl, msaa=4)
    try:
        if r.samples != 4:
            pytest.skip("no 4-sample targets")
        w, h = 13, 9
        positions = sample_resolve.sample_positions(r)
        src = gl.texture((w, h), 4, samples=4, dtype="f4")
        dst = gl.texture((w, h), 4, dtype="f4")
        fbos = gl.framebuffer([src]), gl.framebuffer([dst])
        from pathlib import Path

        vert = (Path(sample_resolve.__file__).parent / "fullscreen.vert").read_text()
        prog = gl.program(vertex_shader=vert, fragment_shader=_WRITE_POSITION)
        vao = gl.vertex_array(prog, [])
        try:
            for k in (1, 2, 5, 11):
                d = still_jitter(k, 1)
                prog["u_jitter"].value = d
                fbos[0].use()
                gl.viewport = (0, 0, w, h)
                gl.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
                vao.render(moderngl.TRIANGLES, vertices=3)
                off = sample_resolve.offsets(positions, d)
                sample_resolve.resolve(r, src, fbos[1], off)
                got = np.frombuffer(dst.read(), np.float32).reshape(h, w, 4)[..., :2].astype(np.float64)
                # the twin, on the samples as written: window position of sample i of pixel (x, y)
                ys, xs = np.mgrid[0:h, 0:w]
                samples = np.stack([np.stack([xs + s[0] - d[0], ys + s[1] - d[1]], -1) for s in positions], 2)
                assert np.allclose(got, sample_resolve.resolve_numpy(samples, off), atol=1e-4)
                # each sample alone: the point it brings lies in the pixel resolved (not at the border,
                # whose samples are clamped)
                inner = (slice(1, h - 1), slice(1, w - 1))
                pixel = np.stack([xs, ys], -1)[inner]
                for i in range(4):
                    point = sample_resolve.resolve_numpy(samples[..., i:i + 1, :], off[i:i + 1])[inner] - pixel
                    assert np.all((point >= 0.0) & (point < 1.0)), (k, i)
                # the blit's samples would not: some point outside its pixel for this jitter
                assert np.any((samples[inner] - pixel[:, :, None] < 0.0) | (samples[inner] - pixel[:, :, None] >= 1.0))
        finally:
            vao.release()
            prog.release()
            for o in (*fbos, src, dst):
                o.release()
    finally:
        r.release()


def _still(r, cam) -> np.ndarray:
    r.render_still(cam)
    tex = r.shown_hdr()
    w, h = r.settings.size
    return np.frombuffer(tex.read(), np.float16 if tex.dtype == "f2" else np.float32).reshape(h, w, 4)[..., :3].astype(np.float64)


def test_a_still_picture_on_the_raster_units_is_box_filtered(gl):
    """Against the box filter's image (one sample a pixel anywhere in it, 256 frames: a path
    tracer's pixel), 16 frames at 4 samples come as close as 64 frames at one sample (the same 64
    samples a pixel, less evenly spread), 64 frames at 4 closer still (llvmpipe: 0.146 and 0.095
    relative error against 0.157). Moved within a regular grid's cells, the rotated 4x pattern's
    samples missed part of the pixel and took part of its neighbours': 0.236 and 0.171."""
    truth_r = _renderer(gl, msaa=1, accumulate=256)
    try:
        cam = truth_r.default_camera()
        truth = _still(truth_r, cam)
    finally:
        truth_r.release()
    err, resolved = {}, {}
    for msaa, frames in ((1, 64), (4, 16), (4, 64)):
        r = _renderer(gl, msaa=msaa, accumulate=frames)
        try:
            if r.samples != msaa:
                pytest.skip("no 4-sample targets")
            err[msaa, frames] = float(np.abs(_still(r, cam) - truth).mean() / truth.mean())
            resolved[msaa] = r.sample_offsets is not None   # the last frame's, resolved by sample_resolve
        finally:
            r.release()
    assert err[4, 16] < 1.1 * err[1, 64] and err[4, 64] < 0.75 * err[1, 64], err
    assert resolved == {1: False, 4: True}
