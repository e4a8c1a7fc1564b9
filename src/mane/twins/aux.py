"""NumPy twin of mane/render/aux_maps.comp (the data set's ground-truth maps), written from its
definition on top of the compute rasteriser's twin (raster.py), in float64:
per sample the nearest segment (smallest window depth; equal depths: the larger id, as the
32-bit path's atomicMax), per pixel the sample with the smallest depth (first in row order),
the depth at the pixel centre on that segment (perspective-correct), the screen angle in
[0, pi), the coherence of the covered samples' doubled angles and the mean coverage alpha."""
from __future__ import annotations

import math

import numpy as np

from .raster import nearest_samples


def screen_angle(pr, i) -> float:
    d = pr["s"][i + 1] - pr["s"][i]
    return math.atan2(d[1], d[0]) % math.pi


def aux_maps(expanded, proj_kw, strands_per_guide: int, scene_depth=None) -> dict:
    """The maps of aux_maps.comp, rows top first like AuxMaps.read."""
    S, N, _ = expanded.shape
    ids, z, cover, pr = nearest_samples(expanded, proj_kw, scene_depth)
    g = proj_kw["grid"]
    W, H = proj_kw["size"][0] // g, proj_kw["size"][1] // g
    eye, fwd = np.asarray(proj_kw["eye"], float), np.asarray(proj_kw["forward"], float)
    pts = expanded.reshape(-1, 8)[:, :3].astype(np.float64)
    seg = np.full((H, W), -1, np.int64)
    depth = np.zeros((H, W))
    angle = np.zeros((H, W))
    conf = np.zeros((H, W))
    alpha = np.zeros((H, W))
    inv_w = 1.0 / np.maximum(np.c_[pts, np.ones(len(pts))] @ np.asarray(proj_kw["view_proj"], float)[3], 1e-30)
    for py in range(H):
        for px in range(W):
            best_z, best = np.inf, -1
            coh = np.zeros(2)
            n = 0
            a_sum = 0.0
            for sy in range(g):
                for sx in range(g):
                    qy, qx = py * g + sy, px * g + sx
                    a_sum += 1.0 - math.exp(-cover[qy, qx])
                    i = ids[qy, qx]
                    if i < 0:
                        continue
                    t = screen_angle(pr, i)
                    coh += (math.cos(2 * t), math.sin(2 * t))
                    n += 1
                    if z[qy, qx] < best_z:
                        best_z, best = z[qy, qx], i
            alpha[py, px] = a_sum / (g * g)
            if best < 0:
                continue
            seg[py, px] = best
            a, b = pr["s"][best], pr["s"][best + 1]
            q = (np.array([px, py], float) + 0.5) * g
            d = b - a
            ts = min(max(float((q - a) @ d) / max(float(d @ d), 1e-12), 0.0), 1.0)
            ib = ts * inv_w[best + 1]
            t = ib / max((1.0 - ts) * inv_w[best] + ib, 1e-20)
            P = pts[best] + t * (pts[best + 1] - pts[best])
            depth[py, px] = (P - eye) @ fwd
            angle[py, px] = screen_angle(pr, best)
            conf[py, px] = np.linalg.norm(coh) / max(n, 1)
    hit = seg >= 0
    strand = np.where(hit, seg // N, 0)
    none = np.uint32(0xFFFFFFFF)
    out = {"segment": seg, "strand": np.where(hit, strand, none).astype(np.uint32),
           "guide": np.where(hit, strand // strands_per_guide, none).astype(np.uint32),
           "depth": depth, "angle": angle, "confidence": conf, "alpha": alpha}
    return {k: v[::-1] for k, v in out.items()}
