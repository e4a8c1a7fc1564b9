"""interpolation="bezier" is the Vulkan hair work's construction (seed-003): per segment the
cubic Bezier b0 = P_i, b1 = P_i + (P_{i+1} - P_{i-1})/6, b2 = P_{i+1} - (P_{i+2} - P_i)/6,
b3 = P_{i+1}. Those control points put the tangent 3 (b1 - b0) = (P_{i+1} - P_{i-1})/2 at each
joint: the Catmull-Rom tangent. A cubic is fixed by its end points and end tangents, so this
Bezier IS the uniform Catmull-Rom curve (as Bezier hulls are, in Bernstein form), with the same
phantom end points: the two give the same image, as they should."""
from __future__ import annotations

import numpy as np

from mane.twins import curve as cr


def test_vulkan_bezier_is_catmull_rom():
    rng = np.random.default_rng(0)
    u = np.linspace(0, 1, 17)
    for _ in range(20):
        P = rng.normal(size=(4, 3))
        np.testing.assert_allclose(cr.vulkan_bezier(*P, u), cr.catmull_rom(*P, u), atol=1e-12)


def test_other_hulls_differ():
    # the identity is the 1/6 of the construction: a hull with another tension is another curve
    rng = np.random.default_rng(1)
    P0, P1, P2, P3 = rng.normal(size=(4, 3))
    u = np.linspace(0, 1, 17)
    b = [P1, P1 + (P2 - P0) / 4, P2 - (P3 - P1) / 4, P2]
    while len(b) > 1:
        b = [(1 - u[:, None]) * x + u[:, None] * y for x, y in zip(b, b[1:])]
    assert np.abs(b[0] - cr.catmull_rom(P0, P1, P2, P3, u)).max() > 1e-2
