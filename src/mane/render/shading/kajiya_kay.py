"""Kajiya-Kay's two terms given the energies of Chiang's fibre (kajiya_kay.glsl).

Kajiya and Kay's model has a Lambertian term over the fibre's half-cylinder and a cos^p
highlight, both of arbitrary scale. mane scales them to what Chiang's fibre of the same
material (the path tracer's model, chiang.py) sends back, seen across the fibre (theta_o 0):

* the highlight ``specular * specular_norm * cos(theta_i + theta_o)^p`` is as wide as Chiang's
  R lobe (standard deviation 2 beta_R in theta_i + theta_o: p = 1 / (2 beta_R)^2) and, at
  ``specular`` 1, has its albedo (the Fresnel reflectance averaged over the fibre's width,
  ``r_albedo``);
* the diffuse term ``color / pi^2`` (directional albedo ``color``, the same toward every
  azimuth) sends back toward the light's side (|phi| < pi/2) what Chiang's TT, TRT and longer
  paths send there: ``color`` = twice their albedo over that half (``diffuse_albedo``). Their
  forward light (TT, most of a light fibre's energy) the isotropic term cannot aim, and a lit
  volume hides it: dual scattering (multiple_scattering "auto") carries it on. Measured against
  the path tracer (docs/quality.md): the albedo of the whole sphere in the diffuse term made
  Sintel 2-3.5x too bright from the diffuse term alone; the eye's inclinations averaged over
  the sphere (Fresnel's rise at grazing) made the highlight 2.4x too bright across the fibre.
"""
from __future__ import annotations

import math

import numpy as np

from .chiang import azimuthal_grid, longitudinal_variances, mp, tilt_angles

N_PHI = 128
N_THETA = 512


def _longitudinal(roughness: float, shift: float) -> np.ndarray:
    """int M_p(theta_i, theta_o) cos theta_i dtheta_i at theta_o 0 for p = R, TT, TRT, 3 (each
    lobe's tilt moves it off the eye's mirror direction, where the cos theta_i of the solid
    angle is less than 1)."""
    ti = -0.5 * math.pi + (np.arange(N_THETA) + 0.5) * (math.pi / N_THETA)
    out = []
    for v, tilt in zip(longitudinal_variances(roughness), tilt_angles(shift)):
        m = mp(np.cos(ti), math.cos(tilt), np.sin(ti), math.sin(tilt), float(v))
        out.append(float((m * np.cos(ti)).sum()) * (math.pi / N_THETA))
    return np.array(out)


def _albedos(sigma_a, eta: float, beta_n: float, roughness: float, shift: float):
    """Chiang's albedos at theta_o 0: (R over the sphere of lights, TT + TRT + longer paths
    from lights toward the eye's side, |phi| < pi/2 (RGB)); the table is even in phi, so twice
    the integral over [0, pi]."""
    phi = (np.arange(N_PHI) + 0.5) * (math.pi / N_PHI)
    n_r, n_tt, n_trt, n_3 = azimuthal_grid(phi, np.zeros(1), sigma_a, eta=eta, beta_n=beta_n, n_h=128)
    m = _longitudinal(roughness, shift)
    d = math.pi / N_PHI
    back = phi < 0.5 * math.pi
    rest = 2.0 * (m[1] * n_tt[0][back].sum(axis=0) * d + m[2] * n_trt[0][back].sum(axis=0) * d
                  + m[3] * n_3[0] * (0.5 * math.pi))
    return 2.0 * m[0] * float(n_r[0].sum()) * d, rest


def r_albedo(eta: float, beta_n: float, roughness: float, shift: float) -> float:
    """Chiang's R lobe's albedo across the fibre (Fresnel averaged over its width)."""
    return _albedos(np.zeros(3), eta, beta_n, roughness, shift)[0]


def diffuse_albedo(sigma_a, eta: float, beta_n: float, roughness: float, shift: float) -> np.ndarray:
    """Kajiya-Kay's ``color`` for absorption ``sigma_a``: twice Chiang's non-R albedo toward
    the light's side, seen across the fibre."""
    return 2.0 * _albedos(sigma_a, eta, beta_n, roughness, shift)[1]


def sigma_a_for_albedo(albedo, *fibre) -> np.ndarray:
    """The absorption whose ``diffuse_albedo`` is ``albedo`` (each channel; bisection in log
    sigma_a); ``fibre``: diffuse_albedo's (eta, beta_n, roughness, shift). An albedo above the
    clear fibre's is reached at sigma_a 0."""
    target = np.clip(np.asarray(albedo, np.float64).reshape(3), 1e-6, None)
    lo, hi = np.full(3, -12.0), np.full(3, 4.0)       # log sigma_a
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        darker = diffuse_albedo(np.exp(mid), *fibre) < target   # too absorbing: go down
        hi = np.where(darker, mid, hi)
        lo = np.where(darker, lo, mid)
    s = np.exp(0.5 * (lo + hi))
    return np.where(target >= diffuse_albedo(np.zeros(3), *fibre), 0.0, s)


def exponent(roughness: float) -> float:
    """p of the highlight cos^p: as wide as Chiang's R lobe (kajiya_kay.glsl's hair_kk_exponent)."""
    return min(max(1.0 / max(4.0 * roughness * roughness, 1e-6), 1.0), 4096.0)


def highlight_albedo(p: float) -> float:
    """The integral of sin(t, l) cos(theta_i + theta_o)^p over the sphere of lights at theta_o 0:
    2 pi int cos^(p + 2) = 2 pi sqrt(pi) Gamma(p/2 + 3/2) / Gamma(p/2 + 2)."""
    return 2.0 * math.pi * math.sqrt(math.pi) * math.exp(math.lgamma(0.5 * p + 1.5) - math.lgamma(0.5 * p + 2.0))


def specular_norm(eta: float, beta_n: float, roughness: float, shift: float) -> float:
    """The highlight's scale at ``specular`` 1: Chiang's R albedo over the cos^p lobe's."""
    return r_albedo(eta, beta_n, roughness, shift) / highlight_albedo(exponent(roughness))
