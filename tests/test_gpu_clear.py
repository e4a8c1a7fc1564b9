"""mane.gpu.clear: a colour texture cleared by a compute shader holds the value in every texel
(odd sizes: the last partial workgroups), and the renderer's frame is the same either way; a
buffer filled by fill_words holds the word everywhere (its NumPy twin: np.full), past one
dispatch's threads (the grid stride) too."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import UsageError
from mane.gpu import clear
from mane.gpu.clear import FORMATS, clear_texture, fill_words

DTYPES = {"f1": np.uint8, "f2": np.float16, "f4": np.float32}


@pytest.mark.gpu
@pytest.mark.parametrize("components,dtype", sorted(FORMATS))
def test_every_texel_takes_the_value(gl, components, dtype):
    size = (37, 19)   # not a multiple of the 16 x 16 workgroup
    rng = np.random.default_rng(1)
    init = rng.uniform(0.1, 0.9, (size[1], size[0], components))
    if dtype == "f1":
        init = (init * 255).astype(np.uint8)
    tex = gl.texture(size, components, init.astype(DTYPES[dtype]).tobytes(), dtype=dtype)
    try:
        value = (0.25, 0.5, 0.75, 1.0)
        clear_texture(gl, tex, value)
        got = np.frombuffer(tex.read(), DTYPES[dtype]).reshape(size[1], size[0], components).astype(np.float64)
        want = np.broadcast_to(np.array(value[:components]), got.shape)
        if dtype == "f1":   # the nearest of 0..255; a tie (0.5 -> 127.5) either way (NVIDIA: 127)
            np.testing.assert_allclose(got, want * 255.0, atol=0.5)
        else:
            np.testing.assert_array_equal(got, want)
    finally:
        tex.release()


@pytest.mark.gpu
def test_unclearable_textures_are_refused_in_one_line(gl):
    tex = gl.texture((8, 8), 3, dtype="f4")
    try:
        with pytest.raises(UsageError, match="cannot clear a 3-component f4 texture") as info:
            clear_texture(gl, tex)
        assert "\n" not in str(info.value)
    finally:
        tex.release()


@pytest.mark.gpu
def test_frame_matches_the_raster_units_clear(gl):
    """A compute-rasterised single-sample frame, its HDR colour cleared by compute and its depth
    over the head's screen box, equals the same frame with the whole target cleared by glClear
    (the renderer's earlier way), bit for bit, and stays so over frames (nothing of the last
    frame leaks into the next)."""
    from mane.grooming.scene import default_groom, default_head
    from mane.render import Renderer, RenderSettings

    head = default_head(2)
    groom = default_groom(head, 60, 8)
    s = RenderSettings(size=(96, 80), rasterizer="compute", head_msaa=False, strands_per_guide=2)
    images = []
    for compute_clear in (True, False):
        r = Renderer(s, ctx=gl)
        try:
            assert r.compute_raster and r.samples == 1
            if not compute_clear:
                r._clear_hdr = lambda fbo, view: fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            r.set_strands(groom)
            r.set_head(head)
            cam = r.default_camera()
            first = r.render_image(cam)
            r.set_head(None)
            second = r.render_image(cam)   # no head: the head's pixels must be cleared away
            images.append((first, second))
        finally:
            r.release()
    np.testing.assert_array_equal(images[0][0], images[1][0])
    np.testing.assert_array_equal(images[0][1], images[1][1])
    assert (images[0][0] != images[0][1]).any()


@pytest.mark.gpu
@pytest.mark.parametrize("words,groups", [(1, None), (70_001, None), (70_001, 3)])
def test_fill_words_sets_every_word(gl, monkeypatch, words, groups):
    """Every word of the buffer, whatever it held, is the value (np.full its twin); with the
    dispatch capped at 3 groups (768 threads) each thread strides over ~91 words."""
    if groups is not None:
        monkeypatch.setattr(clear, "FILL_GROUPS", groups)
    rng = np.random.default_rng(words)
    buf = gl.buffer(rng.integers(0, 2**32, words, dtype=np.uint32).tobytes())
    try:
        for value in (0xFFFFFFFF, 0, 0x3F800000):
            fill_words(gl, buf, value)
            np.testing.assert_array_equal(np.frombuffer(buf.read(), np.uint32), np.full(words, value, np.uint32))
    finally:
        buf.release()


@pytest.mark.gpu
def test_fill_words_fills_the_first_count_words_only(gl):
    """``count``: the OIT methods' clears of a buffer's first words; the rest keep their values."""
    init = np.arange(1000, dtype=np.uint32)
    buf = gl.buffer(init.tobytes())
    try:
        fill_words(gl, buf, 7, count=333)
        want = init.copy()
        want[:333] = 7
        np.testing.assert_array_equal(np.frombuffer(buf.read(), np.uint32), want)
    finally:
        buf.release()


@pytest.mark.gpu
@pytest.mark.parametrize("size,value,count,match", [
    (6, 0, None, "cannot fill a 6-byte buffer"), (8, -1, None, "a fill word must be"),
    (8, 0, 3, "cannot fill 3 words of a 8-byte buffer")])
def test_fill_words_refuses_in_one_line(gl, size, value, count, match):
    buf = gl.buffer(reserve=size)
    try:
        with pytest.raises(UsageError, match=match) as info:
            fill_words(gl, buf, value, count=count)
        assert "\n" not in str(info.value)
    finally:
        buf.release()
