"""The scale of Sadeghi et al.'s pseudo scattering function (sadeghi.glsl): its lobes have unit
height, as published, which made hair 13-20x the path tracer's brightness (docs/quality.md).
mane scales the whole function so that its R lobe (I_R 0.45, ``specular`` 1) has the albedo of
Chiang's R lobe across the fibre (kajiya_kay.r_albedo); TT and TRT keep the paper's ratios to R.

Sadeghi's R lobe, f_R cos theta_i = I_R exp(-((theta_h - alpha) / beta)^2 / 2) cos(phi / 2)
cos theta_i / cos^2 theta_d: over the sphere of lights at theta_o 0 (dw = cos theta_i dtheta_i
dphi) the phi integral of cos(phi / 2) is 4 and theta_i is integrated numerically.
"""
from __future__ import annotations

import math

import numpy as np

from .kajiya_kay import r_albedo

I_R = 0.45          # sadeghi.glsl's HAIR_SADEGHI_I.x
N_THETA = 2048


def r_lobe_albedo(roughness: float, shift: float) -> float:
    """The albedo of Sadeghi's R lobe at theta_o 0 (``specular`` 1, unscaled)."""
    ti = -0.5 * math.pi + (np.arange(N_THETA) + 0.5) * (math.pi / N_THETA)
    th, td = 0.5 * ti, -0.5 * ti
    m = np.exp(-0.5 * ((th - shift) / roughness) ** 2)
    return float(I_R * 4.0 * (m * np.cos(ti) ** 2 / np.maximum(np.cos(td), 1e-2) ** 2).sum() * (math.pi / N_THETA))


def norm(eta: float, beta_n: float, roughness: float, shift: float) -> float:
    """The factor on the whole function (HAIR_SADEGHI_NORM)."""
    return r_albedo(eta, beta_n, roughness, shift) / r_lobe_albedo(roughness, shift)
