"""The scales of Scheuermann's terms (scheuermann.glsl): sin(t, H)^e of unit height, as
published, made hair 24-35x the path tracer's brightness (docs/quality.md). mane scales both
highlights so that the primary one (``specular`` 1, the strand's random at its mean) has the
albedo of Chiang's R lobe across the fibre (kajiya_kay.r_albedo); the secondary keeps its
ratio to it. From melanin, ``color`` (the diffuse term's and the secondary highlight's tint)
makes the wrapped diffuse term send back toward the light's side (|phi| < pi/2) what
Kajiya-Kay's does (kajiya_kay.diffuse_albedo: what Chiang's TT, TRT and longer paths send there).

The primary highlight smoothstep(-1, 0, t.H) sin(t, H)^e, t the tangent tilted toward the eye's
fibre normal N by ``shift``, H = normalize(L + V), e = 1 / roughness^2, integrated over the
sphere of lights at theta_o 0 (dw = cos theta_i dtheta_i dphi) numerically.
"""
from __future__ import annotations

import math

import numpy as np

from . import kajiya_kay

N_GRID = 512


def primary_albedo(roughness: float, shift: float) -> float:
    """The albedo of the primary highlight at theta_o 0 (``specular`` 1, unscaled)."""
    ti = -0.5 * math.pi + (np.arange(N_GRID) + 0.5) * (math.pi / N_GRID)
    ph = -math.pi + (np.arange(N_GRID) + 0.5) * (2.0 * math.pi / N_GRID)
    TI, PH = np.meshgrid(ti, ph, indexing="ij")
    # T = z, the eye V = x (theta_o 0), so N = x; the light at inclination theta_i, azimuth phi from V
    L = np.stack([np.cos(TI) * np.cos(PH), np.cos(TI) * np.sin(PH), np.sin(TI)], -1)
    H = L + np.array([1.0, 0.0, 0.0])
    H /= np.maximum(np.linalg.norm(H, axis=-1, keepdims=True), 1e-12)
    t = np.array([shift, 0.0, 1.0]) / math.hypot(shift, 1.0)
    c = np.clip(H @ t, -1.0, 1.0)
    x = np.clip(c + 1.0, 0.0, 1.0)
    e = min(1.0 / max(roughness, 1e-3) ** 2, 4096.0)
    spec = x * x * (3.0 - 2.0 * x) * np.sqrt(np.maximum(0.0, 1.0 - c * c)) ** e
    w = np.cos(TI) * (math.pi / N_GRID) * (2.0 * math.pi / N_GRID)
    return float((spec * w).sum())


def diffuse_back_albedo() -> float:
    """The wrapped diffuse term's albedo per unit ``color`` from lights on the eye's side
    (|phi| < pi/2) at theta_o 0: (1/pi) mix(0.25, 1, max(N.L, 0)) over those lights."""
    ti = -0.5 * math.pi + (np.arange(N_GRID) + 0.5) * (math.pi / N_GRID)
    ph = -0.5 * math.pi + (np.arange(N_GRID) + 0.5) * (math.pi / N_GRID)
    TI, PH = np.meshgrid(ti, ph, indexing="ij")
    n_l = np.clip(np.cos(TI) * np.cos(PH), 0.0, 1.0)       # N = V = x at theta_o 0
    w = np.cos(TI) * (math.pi / N_GRID) * (math.pi / N_GRID)
    return float(((0.25 + 0.75 * n_l) / math.pi * w).sum())


def color(sigma_a, *fibre) -> np.ndarray:
    """Scheuermann's ``color`` for absorption ``sigma_a`` (``fibre``: eta, beta_n, roughness, shift):
    Kajiya-Kay's diffuse albedo, which sends half of itself toward the light's side, over the
    wrapped term's albedo there."""
    return 0.5 * kajiya_kay.diffuse_albedo(sigma_a, *fibre) / diffuse_back_albedo()


def sigma_a_for_color(color, *fibre) -> np.ndarray:
    """The absorption whose ``color`` is ``color`` (the inverse of ``color``)."""
    kk = np.asarray(color, np.float64) * (2.0 * diffuse_back_albedo())
    return kajiya_kay.sigma_a_for_albedo(kk, *fibre)


def norm(eta: float, beta_n: float, roughness: float, shift: float) -> float:
    """The factor on both highlights (HAIR_SCHEUERMANN_NORM)."""
    return kajiya_kay.r_albedo(eta, beta_n, roughness, shift) / primary_albedo(roughness, shift)
