"""The shading tables' azimuthal integrals as they were before they were vectorised over the
fibre offset h (mane.render.shading.chiang / dual_scattering), kept verbatim as the tests'
reference (tests/test_shading_tables_v1.py): the loop over h of ``azimuthal_average``, the Chiang
table, and the dual-scattering hemisphere integrals and tables of Chiang's fibre (two
``azimuthal_average`` calls). Fresnel and the logistic are copied too; the unchanged
pieces (the logistic's scale, the lobe averages, Zinke's back-scattering equations) are the
library's own."""
from __future__ import annotations

import math

import numpy as np

from mane.render.shading.chiang import HALF_PI, PI, TILES, lobe_shifts, lobe_widths, logistic_scale
from mane.render.shading.dual_scattering import DualTables, _lobe_averages, back_scattering


def _fresnel(cos_i, eta):
    cos_i = np.clip(cos_i, 0.0, 1.0)
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - (1.0 - cos_i * cos_i) / (eta * eta)))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


def _trimmed_logistic(x, s):
    e = np.exp(-np.abs(x) / s)
    norm = 1.0 / (1.0 + math.exp(-PI / s)) - 1.0 / (1.0 + math.exp(PI / s))
    return e / (s * (1.0 + e) ** 2 * norm)


def azimuthal_average(phi, theta_o, sigma_a, *, eta=1.55, beta_n=0.3, n_h=256):
    """(Nbar_R (...,), Nbar_TT (..., 3), Nbar_TRT (..., 3), Nbar_3 (..., 3)) at broadcast
    arrays phi, theta_o (module docstring)."""
    phi, theta_o = np.broadcast_arrays(np.asarray(phi, np.float64), np.asarray(theta_o, np.float64))
    sigma_a = np.asarray(sigma_a, np.float64).reshape(3)
    s = logistic_scale(beta_n)
    sin_o, cos_o = np.sin(theta_o), np.maximum(np.cos(theta_o), 1e-6)
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - (sin_o / eta) ** 2))
    etap = np.sqrt(np.maximum(0.0, eta * eta - sin_o * sin_o)) / cos_o
    n_r = np.zeros(phi.shape)
    n_tt = np.zeros(phi.shape + (3,))
    n_trt = np.zeros(phi.shape + (3,))
    n_3 = np.zeros(phi.shape + (3,))
    gammas = -HALF_PI + (np.arange(n_h) + 0.5) * (PI / n_h)
    for g in gammas:
        h = math.sin(g)
        w = 0.5 * math.cos(g) * (PI / n_h)             # 1/2 dh = 1/2 cos(gamma) dgamma
        f = _fresnel(cos_o * math.cos(g), eta)[..., None]
        sin_gt = h / etap
        cos_gt = np.sqrt(np.maximum(0.0, 1.0 - sin_gt * sin_gt))
        gamma_t = np.arcsin(np.clip(sin_gt, -1.0, 1.0))
        T = np.exp(-sigma_a * (2.0 * cos_gt / cos_t)[..., None])
        a1 = (1.0 - f) ** 2 * T
        a2 = a1 * T * f
        a3 = a2 * f * T / (1.0 - T * f)
        for p in range(3):
            d = phi - (2.0 * p * gamma_t - 2.0 * g + p * PI)
            d = np.mod(d + PI, 2.0 * PI) - PI
            n = w * _trimmed_logistic(d, s)
            if p == 0:
                n_r += n * f[..., 0]
            elif p == 1:
                n_tt += n[..., None] * a1
            else:
                n_trt += n[..., None] * a2
        n_3 += (w / (2.0 * PI)) * a3
    return n_r, n_tt, n_trt, n_3


def azimuthal_table(sigma_a, *, eta=1.55, beta_n=0.3, n_phi=128, n_theta=64, n_h=256) -> np.ndarray:
    """(n_theta, 3 n_phi, 4) float32 texture data (module docstring)."""
    if int(n_phi) < 4 or int(n_theta) < 4:
        raise ValueError("the Chiang table needs at least 4 x 4 texels")
    phi = np.linspace(0.0, PI, int(n_phi))
    theta = np.linspace(0.0, HALF_PI, int(n_theta))
    TH, PH = np.meshgrid(theta, phi, indexing="ij")
    n_r, n_tt, n_trt, n_3 = azimuthal_average(PH, TH, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
    out = np.zeros((int(n_theta), TILES * int(n_phi), 4))
    out[:, :n_phi, :3] = n_tt
    out[:, :n_phi, 3] = n_r
    out[:, n_phi:2 * n_phi, :3] = n_trt
    out[:, 2 * n_phi:, :3] = n_3
    if not np.isfinite(out).all():
        raise FloatingPointError("non-finite Chiang table")
    return out.astype(np.float32)


def chiang_hemisphere_integrals(theta, sigma_a, *, eta=1.55, beta_n=0.3, specular=1.0, n_phi=128, n_h=128):
    """(I_f, I_b), each (len(theta), 4 lobes, 3 colours), for Chiang's fibre with the eye at
    ``theta`` (module docstring)."""
    theta = np.atleast_1d(np.asarray(theta, np.float64))
    ph = (np.arange(n_phi) + 0.5) / n_phi * PI
    TH, PH = np.meshgrid(np.abs(theta), ph, indexing="ij")
    n_r, n_tt, n_trt, n_3 = azimuthal_average(PH, TH, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
    lobes = np.stack([np.repeat(specular * n_r[..., None], 3, axis=-1), n_tt, n_trt, n_3], axis=-2)
    w = 2.0 * PI / n_phi                                  # phi and -phi
    back = ph < HALF_PI
    return lobes[:, ~back].sum(axis=1) * w, lobes[:, back].sum(axis=1) * w


def _precompute_dual_chiang(sigma_a, n, *, eta, roughness, shift, beta_n, specular, d_b) -> DualTables:
    theta = np.linspace(-HALF_PI, HALF_PI, n)
    I_f, I_b = chiang_hemisphere_integrals(theta, sigma_a, eta=eta, beta_n=beta_n, specular=specular)
    a_f, a_b, alpha_f, alpha_b, beta_f2, beta_b2 = _lobe_averages(I_f, I_b, lobe_shifts(shift),
                                                                  lobe_widths(roughness))
    A_b, delta_b, sigma_b2 = back_scattering(a_f, a_b, alpha_f, alpha_b, beta_f2, beta_b2, d_b)
    theta_o = np.linspace(0.0, HALF_PI, n)
    G_f, G_b = chiang_hemisphere_integrals(theta_o, sigma_a, eta=eta, beta_n=beta_n, specular=1.0)
    ng = (G_f + G_b) / (2.0 * PI)
    return DualTables(theta=theta, a_f=a_f, a_b=a_b, alpha_f=alpha_f, alpha_b=alpha_b, beta_f2=beta_f2,
                      beta_b2=beta_b2, A_b=A_b, delta_b=delta_b, sigma_b2=sigma_b2, theta_d=theta_o,
                      ng_r=ng[:, 0, 0], ng_tt=ng[:, 1], ng_trt=ng[:, 2], lobe_f=I_f, lobe_b=I_b,
                      ng_trrt=ng[:, 3])
