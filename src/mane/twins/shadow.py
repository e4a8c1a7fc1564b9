"""Exact light transmittance through a groom of strand segments, for validating the renderer's
shadow methods (deep opacity maps, opacity shadow maps, ADSM, the density ray march, plain
shadow maps).

Each segment p0 -> p1 is a flat ribbon of width w(t) = w0 + (w1 - w0) t (t in [0, 1] along the
segment) turned toward the light: its sides run along cross(T, L), which is what the renderer's
geometry shader rasterises into light 0's maps. For a directional light a ray from X toward
the light (direction L) hits that ribbon exactly when, in the plane perpendicular to L, X lies
within w(t)/2 of the projected segment at the foot t in [0, 1] of the perpendicular (the
ribbon's side is perpendicular to both L and the projected axis), and the ribbon point
p(t) lies ahead of X along L. (A cylinder of diameter w gives the same test, up to its caps.)

A strand is crossed once per run of consecutive hit segments (a ray near a joint of a bent
strand hits the two segments there once), and every crossing passes (1 - alpha) of the light:

    T(X) = prod over strands crossed (1 - alpha)

The segments are those the renderer draws (``mane.render.capture.capture_segments``), so the
reference sees the tessellated, clumped strands with their true widths.
"""
from __future__ import annotations

import numpy as np


def crossings(points, p0, p1, w0, w1, strand, light_dir, *, chunk: int = 256) -> np.ndarray:
    """(M,) number of strand crossings on the ray from each point toward the light.

    points (M, 3); p0, p1 (K, 3) segment ends; w0, w1 (K,) widths (m) at the ends; strand (K,)
    int id of each segment's strand, segments of one strand ordered root to tip and adjacent
    in the arrays; light_dir (3,) toward the light (directional)."""
    X = np.asarray(points, np.float64).reshape(-1, 3)
    a = np.asarray(p0, np.float64)
    b = np.asarray(p1, np.float64)
    w0 = np.asarray(w0, np.float64).reshape(-1)
    w1 = np.asarray(w1, np.float64).reshape(-1)
    strand = np.asarray(strand).reshape(-1)
    L = np.asarray(light_dir, np.float64)
    L = L / np.linalg.norm(L)
    # project onto the plane perpendicular to L
    a_p = a - np.outer(a @ L, L)
    d = b - a
    d_p = d - np.outer(d @ L, L)
    dd = np.maximum(np.einsum("ij,ij->i", d_p, d_p), 1e-30)
    # a hit on segment k continues the previous run when k - 1 is the same strand
    same_prev = np.zeros(len(a), bool)
    same_prev[1:] = strand[1:] == strand[:-1]
    out = np.zeros(len(X), np.int64)
    for s in range(0, len(X), chunk):
        x = X[s:s + chunk]
        x_p = x - np.outer(x @ L, L)
        rel = x_p[:, None, :] - a_p[None, :, :]                     # (m, K, 3)
        t = np.einsum("mkj,kj->mk", rel, d_p) / dd[None, :]
        inside = (t >= 0.0) & (t <= 1.0)
        tc = np.clip(t, 0.0, 1.0)
        foot = rel - tc[..., None] * d_p[None]
        dist2 = np.einsum("mkj,mkj->mk", foot, foot)
        width = w0[None, :] + (w1 - w0)[None, :] * tc
        ahead = ((a[None, :, :] + tc[..., None] * d[None]) - x[:, None, :]) @ L > 0.0
        hit = inside & (dist2 <= (0.5 * width) ** 2) & ahead
        prev = np.zeros_like(hit)
        prev[:, 1:] = hit[:, :-1] & same_prev[None, 1:]
        out[s:s + chunk] = np.count_nonzero(hit & ~prev, axis=1)
    return out


def exact_transmittance(points, p0, p1, w0, w1, strand, light_dir, alpha) -> np.ndarray:
    """(M,) prod(1 - alpha) over the strands crossed toward a directional light (see module doc)."""
    n = crossings(points, p0, p1, w0, w1, strand, light_dir)
    return (1.0 - float(alpha)) ** n


def segments_for_reference(seg: dict) -> dict:
    """capture_segments output -> arrays ordered by strand then along it (root to tip)."""
    order = np.lexsort((seg["s0"], seg["id"]))
    return {"p0": seg["p0"][order], "p1": seg["p1"][order], "w0": seg["width"][order, 0],
            "w1": seg["width"][order, 1], "strand": seg["id"][order]}
