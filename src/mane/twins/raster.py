"""NumPy twin of the compute rasteriser (raster_view.glsl, raster_segment.glsl, hair_raster.comp):
the same projection and scan conversion, written from their definitions, in float64."""
from __future__ import annotations

import math

import numpy as np


def project(points, view_proj, eye, forward, ortho, pixel_size, min_pixel_width, size, grid, lines=False):
    """points (M, 4): xyz, width -> dict of s (M, 2) samples, window_z, depth, half_width, coverage, ok.
    ``lines``: one pixel wide and opaque whatever the width (geometry="lines")."""
    P = np.asarray(points, np.float64)
    c = np.c_[P[:, :3], np.ones(len(P))] @ np.asarray(view_proj, np.float64).T
    ok = c[:, 3] > 1e-6
    w = np.where(ok, c[:, 3], 1.0)
    ndc = c[:, :3] / w[:, None]
    s = (ndc[:, :2] * 0.5 + 0.5) * np.asarray(size, np.float64)
    depth = (P[:, :3] - eye) @ forward
    pixel = pixel_size if ortho else pixel_size * np.maximum(depth, 1e-4)
    ws = P[:, 3] / pixel * grid
    wmin = 1.0 if min_pixel_width > 0 else 0.0
    coverage = np.where(ws < wmin, ws / max(wmin, 1e-30), 1.0)
    half = 0.5 * np.maximum(ws, wmin)
    if lines:
        coverage, half = np.ones_like(coverage), np.full_like(half, 0.5 * grid)
    return {"s": s, "window_z": ndc[:, 2] * 0.5 + 0.5, "depth": depth, "half_width": half,
            "coverage": coverage, "ok": ok}


def scan_segment(a, b, za, zb, ha, hb, ca, cb, size):
    """The samples (x, y, z, coverage) segment a-b covers: along the major axis the sample
    columns with centres in [a, b), across it the centres within h / cos(angle), half-open."""
    a, b = np.array(a, float), np.array(b, float)
    W, H = size
    d = b - a
    steep = abs(d[1]) > abs(d[0])
    if steep:
        a, b, d, W, H = a[::-1], b[::-1], d[::-1], H, W
    if d[0] < 0:
        a, b, d = b, a, -d
        za, zb, ha, hb, ca, cb = zb, za, hb, ha, cb, ca
    out = []
    if not d[0] > 1e-6:
        return out
    inv_cos = math.hypot(*d) / d[0]
    x0 = max(math.ceil(a[0] - 0.5), 0)
    x1 = min(math.ceil(b[0] - 0.5) - 1, W - 1)
    for x in range(x0, x1 + 1):
        t = (x + 0.5 - a[0]) / d[0]
        y = a[1] + t * d[1]
        h = min((ha + t * (hb - ha)) * inv_cos, 64.0)
        y0 = max(math.ceil(y - h - 0.5), 0)
        y1 = min(math.ceil(y + h - 0.5) - 1, H - 1)
        for yy in range(y0, y1 + 1):
            q = (yy, x) if steep else (x, yy)
            out.append((q[0], q[1], za + t * (zb - za), ca + t * (cb - ca)))
    return out


def nearest_samples(expanded, proj_kw, scene_depth=None):
    """expanded (strands, points, 8) -> (ids (H, W) of the nearest segment's first point, -1
    none; its window depth z (H, W); cover (H, W) = -sum log(1 - coverage); the projection) in
    the sample grid, as hair_raster.comp (equal depths: the larger id)."""
    S, N, _ = expanded.shape
    W, H = proj_kw["size"]
    pts = expanded.reshape(-1, 8)
    pr = project(pts[:, :4], **proj_kw)
    best = np.full((H, W), np.inf)
    ids = np.full((H, W), -1, np.int64)
    cover = np.zeros((H, W))
    g = proj_kw["grid"]
    for strand in range(S):
        for j in range(N - 1):
            i = strand * N + j
            if not (pr["ok"][i] and pr["ok"][i + 1]):
                continue
            for x, y, z, c in scan_segment(pr["s"][i], pr["s"][i + 1], pr["window_z"][i], pr["window_z"][i + 1],
                                           pr["half_width"][i], pr["half_width"][i + 1], pr["coverage"][i],
                                           pr["coverage"][i + 1], (W, H)):
                if not 0.0 <= z < 1.0:
                    continue
                if scene_depth is not None and z >= scene_depth[y // g, x // g]:
                    continue
                cover[y, x] += -math.log(1.0 - min(max(c, 0.0), 0.9999))
                if z < best[y, x] or (z == best[y, x] and i > ids[y, x]):
                    best[y, x], ids[y, x] = z, i
    return ids, best, cover, pr


def rasterize(expanded, proj_kw, scene_depth=None):
    """expanded (strands, points, 8) -> (ids (H, W) of the nearest segment's first point, -1
    none; cover (H, W) = -sum log(1 - coverage)) in the sample grid, as hair_raster.comp."""
    ids, _, cover, _ = nearest_samples(expanded, proj_kw, scene_depth)
    return ids, cover


def deep_opacity(expanded, proj_kw, layer_ends, strand_opacity):
    """Deep opacity maps as dom_raster.comp builds them: (H, W, 4) of O1, O2, O3, z0 (inf: no
    hair); z0 the nearest linear depth, each fragment adding strand_opacity x coverage to its
    layer (depth - z0 < layer end) and every layer behind it."""
    S, N, _ = expanded.shape
    W, H = proj_kw["size"]
    pr = project(expanded.reshape(-1, 8)[:, :4], **proj_kw)
    frags = []
    for strand in range(S):
        for j in range(N - 1):
            i = strand * N + j
            if pr["ok"][i] and pr["ok"][i + 1]:
                frags += scan_segment(pr["s"][i], pr["s"][i + 1], pr["depth"][i], pr["depth"][i + 1],
                                      pr["half_width"][i], pr["half_width"][i + 1], pr["coverage"][i],
                                      pr["coverage"][i + 1], (W, H))
    out = np.zeros((H, W, 4))
    out[..., 3] = np.inf
    frags = [f for f in frags if f[2] > 0]
    for x, y, z, _ in frags:
        out[y, x, 3] = min(out[y, x, 3], z)
    for x, y, z, c in frags:
        dz = z - out[y, x, 3]
        a = strand_opacity * c
        out[y, x, 0] += a if dz < layer_ends[0] else 0.0
        out[y, x, 1] += a if dz < layer_ends[1] else 0.0
        out[y, x, 2] += a
    return out
