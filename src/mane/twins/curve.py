"""NumPy twins of the per-segment curve schemes (strand_common.glsl's eval_curve), written
from their definitions."""
from __future__ import annotations

import numpy as np


def catmull_rom(P0, P1, P2, P3, u):
    """Uniform Catmull-Rom on P1 -> P2: the cubic Hermite with tangents (P2 - P0)/2, (P3 - P1)/2."""
    u = np.asarray(u, dtype=np.float64)[:, None]
    m1, m2 = (P2 - P0) / 2, (P3 - P1) / 2
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    return h00 * P1 + h10 * m1 + h01 * P2 + h11 * m2


def vulkan_bezier(P0, P1, P2, P3, u):
    """The Vulkan hair work's segment (seed-003): control points b0 = P_i, b1 = P_i + (P_{i+1} -
    P_{i-1})/6, b2 = P_{i+1} - (P_{i+2} - P_i)/6, b3 = P_{i+1}, evaluated by de Casteljau."""
    u = np.asarray(u, dtype=np.float64)[:, None]
    b = [P1, P1 + (P2 - P0) / 6, P2 - (P3 - P1) / 6, P2]
    while len(b) > 1:
        b = [(1 - u) * x + u * y for x, y in zip(b, b[1:])]
    return b[0]
