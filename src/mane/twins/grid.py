"""NumPy twins of the grid kernels, written from the equations, in float64."""
from __future__ import annotations

import numpy as np


def masses(inverse_masses, pinned_mass=1.0):
    w = np.asarray(inverse_masses, np.float64)
    return np.where(w > 0, 1.0 / np.where(w > 0, w, 1.0), float(pinned_mass))


def node_stencil(points, lo, hi, resolution):
    """Lower corner node (n,3) int and fraction (n,3) of each point on a node grid over [lo, hi]."""
    R = resolution
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    g = (np.asarray(points, np.float64) - lo) / (hi - lo) * (R - 1)
    g = np.clip(g, 0.0, R - 1)
    base = np.minimum(np.floor(g).astype(np.int64), R - 2)
    return base, g - base


def corners():
    return np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])


def splat(points, values, lo, hi, resolution):
    """Trilinear splat of per-point ``values`` (n, k) onto (R, R, R, k) nodes indexed [x, y, z]."""
    R = resolution
    values = np.asarray(values, np.float64)
    values = values.reshape(len(values), -1)
    base, frac = node_stencil(points, lo, hi, R)
    out = np.zeros((R ** 3, values.shape[1]))
    for c in corners():
        w = np.prod(np.where(c == 1, frac, 1.0 - frac), axis=1)
        n = base + c
        flat = n[:, 0] * R * R + n[:, 1] * R + n[:, 2]
        for k in range(values.shape[1]):
            out[:, k] += np.bincount(flat, weights=w * values[:, k], minlength=R ** 3)
    return out.reshape(R, R, R, -1)


def gather(points, field, lo, hi):
    """Trilinear interpolation of a node field (R, R, R, k) at points."""
    R = field.shape[0]
    base, frac = node_stencil(points, lo, hi, R)
    out = np.zeros((len(base), field.shape[-1]))
    for c in corners():
        w = np.prod(np.where(c == 1, frac, 1.0 - frac), axis=1)
        n = base + c
        out += w[:, None] * field[n[:, 0], n[:, 1], n[:, 2]]
    return out


def grid_friction(positions4, velocities3, lo, hi, resolution, friction, pinned_mass=1.0):
    """Petrovic smoothing: returns (new velocities, density, node velocity)."""
    p = np.asarray(positions4, np.float64)
    v = np.asarray(velocities3, np.float64)[:, :3]
    m = masses(p[:, 3], pinned_mass)
    acc = splat(p[:, :3], np.column_stack([m, m[:, None] * v]), lo, hi, resolution)
    density = acc[..., 0]
    node_v = np.divide(acc[..., 1:], density[..., None], out=np.zeros_like(acc[..., 1:]),
                       where=density[..., None] > 1e-30)
    vg = gather(p[:, :3], node_v, lo, hi)
    new = (1.0 - friction) * v + friction * vg
    new = np.where((p[:, 3] > 0)[:, None], new, v)
    return new, density, node_v
