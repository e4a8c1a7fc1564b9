"""Light 0's visibility at world points, as the renderer's shadow method computes it.

    r.render(camera, lights)                     # builds the frame's shadow maps
    T = probe_visibility(r, points)              # (M,) in [0, 1], same look-up as the shading
    B = probe_visibility(r, points, term="behind")   # light0_visibility_ms's terms

A compute shader (``passes/shadow_probe.comp``) includes ``lighting.glsl`` with the renderer's
SHADOWS method, binds the last frame's maps exactly as the hair pass does and writes
``light0_visibility(P)`` per point to a buffer. For validation against an exact ray cast
(src/mane/twins/shadow.py) and debugging.
"""
from __future__ import annotations

import numpy as np

from ..gpu.glsl import compute_shader
from .bindings import B_PROBE_OUT, B_PROBE_POINTS
from .passes.base import HERE, RENDER_DIR, bind_lighting, set_uniform, shadow_defines


TERMS = ("visibility", "direct", "ms", "behind")


def probe_visibility(renderer, points, frame=None, term: str = "visibility") -> np.ndarray:
    """(M,) float32 visibility of light 0 at ``points`` (M, 3) metres, from ``frame`` (default:
    the last). ``term``: "visibility" (light0_visibility), or light0_visibility_ms's "direct",
    "ms" (the multiple scattering's transmittance) or "behind" (the share of it that meets hair
    beyond the point, which scales light 0's multiple scattering)."""
    if term not in TERMS:
        raise ValueError(f"term must be one of {', '.join(TERMS)}, got {term!r}")
    frame = frame if frame is not None else renderer.last_frame
    if frame is None:
        raise ValueError("render a frame first: the shadow maps come from it")
    pts = np.asarray(points, np.float32).reshape(-1, 3)
    m = len(pts)
    if m == 0:
        return np.zeros(0, np.float32)
    ctx = renderer.ctx
    cs = compute_shader(ctx, HERE / "shadow_probe.comp", shadow_defines(ctx, renderer.settings),
                        include_dirs=[RENDER_DIR])
    bind_lighting(renderer, cs, frame)
    data = np.zeros((m, 4), np.float32)
    data[:, :3] = pts
    src = ctx.buffer(data.tobytes())
    out = ctx.buffer(reserve=m * 4)
    try:
        src.bind_to_storage_buffer(B_PROBE_POINTS)
        out.bind_to_storage_buffer(B_PROBE_OUT)
        set_uniform(cs, "u_probe_count", m)
        set_uniform(cs, "u_probe_term", TERMS.index(term))
        cs.run((m + 63) // 64)
        ctx.memory_barrier()
        return np.frombuffer(out.read(), np.float32).copy()
    finally:
        src.release()
        out.release()
