"""FrameReadback (mane.render.readback): frames read one frame late, through staging buffers
behind a fence, are byte for byte what reading each frame at once gives (Renderer.read_image,
AuxMaps.read, read_hdr); and the fence (mane.gpu.fence) waits."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import UsageError
from mane.grooming.scene import default_scene
from mane.render import Renderer, RenderSettings
from mane.render.aux_maps import AuxMaps, read_hdr
from mane.render.readback import FrameReadback

pytestmark = pytest.mark.gpu


def test_reading_a_frame_late_gives_its_bytes(gl):
    groom, head = default_scene(num_guides=30, points=8, subdivisions=3)
    s = RenderSettings(size=(48, 40), rasterizer="compute", msaa=4, shadows="none", strands_per_guide=2, segments=14)
    r = Renderer(s, ctx=gl, profile=False)
    r.set_strands(groom)
    r.set_head(head)
    aux = AuxMaps(r)
    rb = FrameReadback(r, aux, hdr=True)
    cams = [r.default_camera(a, 10.0) for a in (0.0, 35.0, 70.0)]
    try:
        now = []   # each frame read at once
        for cam in cams:
            r.render(cam)
            now.append({"rgb": r.read_image(), "hdr": read_hdr(r), **aux.read()})
        late = []   # frame N read after frame N + 1 was issued
        r.render(cams[0])
        slot = rb.start()
        for cam in cams[1:]:
            r.render(cam)
            nxt = rb.start()
            late.append(rb.read(slot)[0])
            slot = nxt
        late.append(rb.read(slot)[0])
        a, b = rb.start(), rb.start()
        with pytest.raises(UsageError, match="still pending"):
            rb.start()   # both slots hold unread frames
        assert np.array_equal(rb.read(a)[0]["rgb"], rb.read(b)[0]["rgb"])   # the last frame twice
        with pytest.raises(UsageError, match="no frame started"):
            rb.read(b)
    finally:
        rb.release()
        aux.release()
        r.release()
    assert not np.array_equal(now[0]["rgb"], now[1]["rgb"])   # the views differ
    for a, b in zip(now, late):
        assert set(a) == set(b)
        for k in a:
            assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k]), k


def test_maps_without_segment_are_the_same_maps(gl):
    groom, _ = default_scene(num_guides=20, points=8, subdivisions=3)
    r = Renderer(RenderSettings(size=(32, 24), rasterizer="compute", shadows="none", segments=14), ctx=gl,
                 profile=False)
    r.set_strands(groom)
    aux = AuxMaps(r)
    rb = FrameReadback(r, aux, segment=False)
    try:
        r.render(r.default_camera(20.0, 5.0))
        full = aux.read()
        got, _ = rb.read(rb.start())
    finally:
        rb.release()
        aux.release()
        r.release()
    assert set(got) == set(full) - {"segment"} | {"rgb"}
    assert (full["segment"] >= 0).any()
    for k in set(got) - {"rgb"}:
        assert got[k].dtype == full[k].dtype and np.array_equal(got[k], full[k]), k


def test_fence_waits_for_the_gpu(gl):
    from mane.gpu import fence

    assert fence.available()   # Mesa's and NVIDIA's GL have glFenceSync
    buf = gl.buffer(np.arange(1 << 16, dtype=np.float32).tobytes())
    f = fence.Fence()
    assert f.wait() >= 0.0 and f._sync is None   # released once passed
    assert np.frombuffer(buf.read(), np.float32)[-1] == (1 << 16) - 1
    # asked without waiting: False while the GPU is behind it (not asserted: it may be done at
    # once), True once the GPU is past it, then released
    f = fence.Fence()
    gl.finish()
    assert f.done() and f._sync is None
    assert fence.Fence().wait() >= 0.0
    buf.release()
