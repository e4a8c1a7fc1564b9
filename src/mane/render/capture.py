"""Read back the tessellated strands: every segment the geometry shader emits, appended to a
buffer (the ``CAPTURE`` build of ``hair.geom``) with the rasteriser off. For tests and debugging.

    seg = capture_segments(renderer, camera)
    seg["p0"], seg["p1"]      # (M, 3) segment ends (after clump offsets)
    seg["s0"], seg["s1"]      # (M,) parameter along the strand, root 0 .. tip 1
    seg["t0"], seg["t1"]      # (M, 3) unit tangents of the curve
    seg["id"]                 # (M,) guide * strands_per_guide + strand
    seg["corners"]            # (M, 4, 3) ribbon corners: end 0 (-side, +side), end 1 (-side, +side)
    seg["width"]              # (M, 2) strand width (m) at both ends before the pixel minimum
"""
from __future__ import annotations

import numpy as np

from .bindings import B_CAPTURE
from .passes.base import PASS_SHADOW_DEPTH, draw_hair, hair_program, set_uniform


def capture_segments(renderer, camera=None, *, max_segments: int | None = None, view=None) -> dict:
    """Every segment of one hair draw from ``camera`` (default: the renderer's framing).

    The draw goes to a 1x1 target: llvmpipe skips the geometry shader under
    GL_RASTERIZER_DISCARD, so the rasteriser stays on."""
    r = renderer
    if r.strands is None:
        raise ValueError("the renderer has no strands")
    if view is None:
        camera = camera if camera is not None else r.default_camera()
        view = r.camera_view(camera)
    if max_segments is None:
        max_segments = r.segment_capacity
    ctx = r.ctx
    r.strands.update_frames()
    prog = hair_program(r, PASS_SHADOW_DEPTH, capture=True)
    buf = ctx.buffer(reserve=16 + max_segments * 8 * 16)
    buf.write(np.zeros(4, np.uint32).tobytes())
    buf.bind_to_storage_buffer(B_CAPTURE)
    set_uniform(prog, "u_capture_max", int(max_segments))
    tex = ctx.texture((1, 1), 1, dtype="f4")
    previous = ctx.fbo
    fbo = ctx.framebuffer([tex])
    fbo.use()
    ctx.disable(ctx.DEPTH_TEST)
    ctx.disable(ctx.BLEND)
    try:
        draw_hair(r, prog, view, lod_eye=view.eye)
    finally:
        if previous is not None:   # not the released one left bound (gpu.context says why)
            previous.use()
        fbo.release()
        tex.release()
    ctx.memory_barrier()
    count = int(np.frombuffer(buf.read(size=4), np.uint32)[0])
    m = min(count, max_segments)
    if m == 0:
        buf.release()
        raise RuntimeError(f"nothing captured (count {count})")
    rec = np.frombuffer(buf.read(size=m * 8 * 16, offset=16), np.float32).reshape(m, 8, 4)
    buf.release()
    return {
        "count": count,
        "p0": rec[:, 0, :3].copy(), "p1": rec[:, 1, :3].copy(),
        "s0": rec[:, 0, 3].copy(), "s1": rec[:, 1, 3].copy(),
        "t0": rec[:, 2, :3].copy(), "t1": rec[:, 3, :3].copy(),
        "id": np.rint(rec[:, 2, 3]).astype(np.int64),
        "alpha0": rec[:, 3, 3].copy(),
        "corners": rec[:, 4:8, :3].copy(),
        "width": rec[:, 4:8:2, 3].copy(),
    }


def strands_from_segments(seg: dict) -> dict[int, np.ndarray]:
    """id -> (K+1, 4) points (xyz, s) of each captured strand ordered root to tip."""
    out = {}
    for i in np.unique(seg["id"]):
        m = seg["id"] == i
        s0, s1 = seg["s0"][m], seg["s1"][m]
        p0, p1 = seg["p0"][m], seg["p1"][m]
        order = np.argsort(s0)
        pts = np.concatenate([np.c_[p0[order], s0[order]], np.c_[p1[order][-1:], s1[order][-1:]]])
        out[int(i)] = pts
    return out
