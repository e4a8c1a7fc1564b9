"""The exact transparency reference: every hair fragment (an unbounded A-buffer read back),
sorted by depth per pixel and blended front to back in float64 on the CPU, over the opaque
scene; then the resolve pass's tone mapping and sRGB encoding in NumPy.

    ref = reference(renderer_settings, groom, head, camera, lights, ctx)
    ref["image"]        # (H, W, 3) uint8, top row first, as Renderer.read_image()
    ref["fragments"]    # the read-back fragments (pixel, depth, rgba, node)

Ties in depth are broken by node index, as the GPU resolve does.
"""
from __future__ import annotations

import numpy as np


def blend_fragments(pixel, depth, rgba, size, node=None, under=None):
    """(H, W, 4) float64 premultiplied HDR, bottom row first: the fragments of each pixel
    sorted by (depth, node) and blended front to back ("under"), then over ``under`` (the HDR
    colour before the hair, premultiplied; None: transparent black)."""
    w, h = size
    pixel = np.asarray(pixel, np.int64)
    depth = np.asarray(depth, np.float64)
    rgba = np.asarray(rgba, np.float64)
    node = np.arange(len(pixel)) if node is None else np.asarray(node, np.int64)
    order = np.lexsort((node, depth, pixel))
    pixel, rgba = pixel[order], rgba[order]
    # rank within the pixel's run
    start = np.r_[0, np.flatnonzero(np.diff(pixel)) + 1]
    run = np.repeat(start, np.diff(np.r_[start, len(pixel)]))
    rank = np.arange(len(pixel)) - run
    C = np.zeros((w * h, 3))
    T = np.ones(w * h)
    for r in range(int(rank.max()) + 1 if len(rank) else 0):
        sel = rank == r
        p = pixel[sel]
        C[p] += T[p, None] * rgba[sel, :3]
        T[p] *= 1.0 - rgba[sel, 3]
    out = np.zeros((w * h, 4))
    out[:, :3] = C
    out[:, 3] = 1.0 - T
    if under is not None:
        u = np.asarray(under, np.float64).reshape(-1, 4)
        out[:, :3] += T[:, None] * u[:, :3]
        out[:, 3] += T * u[:, 3]
    return out.reshape(h, w, 4)


def srgb_to_linear(c):
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def resolve_display(hdr, background=(0.0, 0.0, 0.0), exposure: float = 1.0, tone: str = "aces"):
    """resolve.comp (no supersampling) in NumPy: (H, W, 4) premultiplied HDR, bottom row
    first -> (H, W, 3) uint8, top row first."""
    c = np.asarray(hdr, np.float64)
    a = np.clip(c[..., 3], 0.0, 1.0)
    rgb = np.where(a[..., None] > 1e-5, c[..., :3] / np.maximum(c[..., 3:], 1e-5), 0.0)
    x = rgb * exposure
    if tone == "aces":
        mapped = np.clip((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)
    elif tone == "reinhard":
        mapped = x / (1.0 + x)
    else:
        mapped = np.clip(x, 0.0, 1.0)
    bg = srgb_to_linear(background)
    out = mapped * a[..., None] + bg * (1.0 - a[..., None])
    out = np.clip(out, 0.0, 1.0)
    s = np.where(out <= 0.0031308, 12.92 * out, 1.055 * out ** (1.0 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)[::-1].copy()


def collect_fragments(settings, groom, head, camera, lights, ctx, max_tries: int = 6) -> dict:
    """Render with an A-buffer (triangles: rasterizer="hardware") whose pool grows until nothing
    overflows; the fragments and the HDR colour under the hair."""
    from ..render import Renderer

    r = Renderer(settings.replace(oit="a_buffer", oit_k=0, rasterizer="hardware"), ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        p = r.get_pass("oit")
        p.capture_under = True
        for _ in range(max_tries):
            frame = r.render(camera, lights)
            st = r.oit_stats()
            if st["oit_overflow"] == 0:
                break
        else:
            raise RuntimeError(f"the A-buffer still overflows after {max_tries} frames: {st}")
        frags = p.method.read_fragments()
        frags["under"] = frame.targets["oit_under"]
        frags["gpu_image"] = r.read_image()
        frags["stats"] = st
        return frags
    finally:
        r.release()


def reference(settings, groom, head, camera, lights, ctx) -> dict:
    """The exact image (uint8, top row first) and its HDR, with the fragments it came from."""
    f = collect_fragments(settings, groom, head, camera, lights, ctx)
    hdr = blend_fragments(f["pixel"], f["depth"], f["rgba"], f["size"], f["node"], f["under"])
    return {"image": display(hdr, settings), "hdr": hdr, "fragments": f}


def image_error(image, ref) -> dict:
    """Mean and max absolute difference in [0, 1] units (of 255), over all pixels and channels."""
    d = np.abs(np.asarray(image, np.float64) - np.asarray(ref, np.float64)) / 255.0
    return {"mean": float(d.mean()), "max": float(d.max()), "p99": float(np.quantile(d, 0.99)),
            "pixels_over_1_255": int((d.max(axis=-1) > 1.0 / 255 + 1e-9).sum())}


# ---------------------------------------------------------------- the compute rasteriser's reference
def collect_compute_fragments(settings, groom, head, camera, lights, ctx) -> dict:
    """Every fragment of the compute rasteriser (settings.rasterizer="compute": a (pixel,
    segment) pair in front of the head) with its premultiplied colour, recorded by the compute
    OIT's capture pass (an append of every fragment, no per-pixel structure), and the HDR
    colour under the hair."""
    from ..render import Renderer

    r = Renderer(settings.replace(oit="a_buffer", oit_k=0, rasterizer="compute"), ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        p = r.get_pass("oit")
        p.capture_under = True
        m = p.current()
        assert getattr(m, "compute", False), "the compute OIT path was not chosen"
        m.capture = True
        frame = r.render(camera, lights)
        f = dict(m.captured)
        f["under"] = frame.targets["oit_under"]
        f["gpu_image"] = r.read_image()
        f["stats"] = r.oit_stats()
        f["view"] = frame.view
        f["expanded"] = r.get_pass("expand").read()
        return f
    finally:
        r.release()


def compute_reference(settings, groom, head, camera, lights, ctx) -> dict:
    """The exact image of the compute rasteriser's fragments: each pixel's sorted by window
    depth (ties by segment id, as the compute resolves break them) and blended front to back
    in float64 over the scene, then resolve.comp in NumPy."""
    f = collect_compute_fragments(settings, groom, head, camera, lights, ctx)
    hdr = blend_fragments(f["pixel"], f["window_z"], f["rgba"], f["size"], f["segment"], f["under"])
    return {"image": display(hdr, settings), "hdr": hdr, "fragments": f}


def per_pixel_sorted(f) -> list:
    """The fragments of each pixel, sorted by (window depth, segment): a list of index arrays
    (by pixel index) into the fragment arrays; pixels without fragments are absent (dict)."""
    order = np.lexsort((f["segment"], f["window_z"], f["pixel"]))
    pix = f["pixel"][order]
    start = np.r_[0, np.flatnonzero(np.diff(pix)) + 1, len(pix)]
    return {int(pix[a]): order[a:b] for a, b in zip(start[:-1], start[1:])}


def display(hdr, settings):
    return resolve_display(hdr, settings.background, settings.exposure, settings.tone_mapping)
