"""Chiang, Bitterli, Tappan and Burley 2016, "A Practical and Controllable Hair and Fur Model
for Production Path Tracing" (the model of pbrt-v4's HairBxDF and Mitsuba 3's ``hair``), in a
real-time form: the azimuthal part averaged over the fibre offset h in a small table, the
longitudinal part analytic in the shader (chiang.glsl). src/mane/twins/chiang.py is
the NumPy twin (from the equations, integrating over h itself); it matches Mitsuba 3.9's own
``hair`` BSDF evaluation to 0.5 % (tests/test_chiang.py).

The far-field fibre (w_o = V the eye, w_i = L the light, T the tangent root -> tip):

    hair_bsdf = sum_{p=0}^{3} M_p(theta_i, theta_o^p) Nbar_p(phi, theta_o)
    Nbar_p(phi, theta_o) = 1/2 int_{-1}^{1} A_p(theta_o, h) N_p(phi; h) dh        (p = 0, 1, 2)
    Nbar_3(theta_o)      = 1/2 int_{-1}^{1} A_3(theta_o, h) dh / (2 pi)

This is exactly pbrt's ``fsum`` averaged over h: A_p and N_p depend on h and on the eye's
inclination theta_o (Fresnel at cos theta_o cos gamma_o, the Bravais index eta', the path
2 cos gamma_t / cos theta_t) but not on the light's, and M_p does not depend on h, so the average
factors into M_p times a table over (phi, theta_o). Equations (Chiang 2016 eqs. 3-12, d'Eon
et al. 2011 eq. 7; src/mane/twins/chiang.py's docstring has them in full):

* M_p: d'Eon's longitudinal lobe with variance v_p (low-variance log form for v <= 0.1),
  v_0 = (2 roughness)^2 (mane's ``roughness`` is Marschner's beta_R, the R lobe's standard
  deviation in theta_h; Chiang's beta_m maps to it by ``roughness_from_beta_m``),
  v_1 = v_0 / 4, v_2 = v_3 = 4 v_0; the cuticle tilt alpha = ``shift`` rotates theta_o by
  -2 alpha (R), +alpha (TT), +4 alpha (TRT) (pbrt's sin 2^k alpha terms).
* A_p: Fresnel f (IOR ``eta``, 1.55), transmittance T = exp(-sigma_a 2 cos gamma_t / cos theta_t):
  A_0 = f, A_1 = (1 - f)^2 T, A_2 = A_1 T f, A_3 = A_2 f T / (1 - T f) (all longer paths).
* N_p: trimmed logistic around Phi(p, h) = 2 p gamma_t - 2 gamma_o + p pi, scale
  s = sqrt(pi / 8) (0.265 beta_n + 1.194 beta_n^2 + 5.372 beta_n^22).

Table (``azimuthal_table``): Nbar over phi in [0, pi] (even in phi: h and -h mirror) and
theta_o in [0, pi/2] (even in theta_o), grid points at texel centres (phi_j = pi j / (n_phi - 1),
theta_k = pi/2 k / (n_theta - 1)); three tiles side by side in one RGBA32F texture of
(3 n_phi) x n_theta texels: tile 0 = (Nbar_TT.rgb, Nbar_R), tile 1 = (Nbar_TRT.rgb, 0),
tile 2 = (Nbar_3.rgb, 0) (constant along phi). The h integral runs over gamma_o = asin h
(uniform steps in the azimuth of the exit, where the R lobe's Phi = -2 gamma_o moves evenly;
dh = cos gamma_o dgamma_o), ``n_h`` midpoints. 128 x 64 texels, 384 KiB, built in ~0.3 s per
material; cached per material by ShadingSettings.
"""
from __future__ import annotations

import math

import numpy as np

PI = math.pi
HALF_PI = 0.5 * math.pi
SQRT_PI_OVER_8 = math.sqrt(math.pi / 8.0)
TILES = 3


def longitudinal_variances(roughness: float) -> np.ndarray:
    """v_0..v_3 of M_p from mane's roughness (beta_R, radians)."""
    v0 = (2.0 * float(roughness)) ** 2
    return np.array([v0, 0.25 * v0, 4.0 * v0, 4.0 * v0])


def beta_m_width(beta_m: float) -> float:
    """Chiang eq. 7: the R lobe's standard deviation in theta_o, sqrt(v_0), from beta_m."""
    b = float(beta_m)
    return 0.726 * b + 0.812 * b * b + 3.7 * b**20


def roughness_from_beta_m(beta_m: float) -> float:
    """mane's ``roughness`` equivalent to Chiang's / Mitsuba's longitudinal roughness beta_m."""
    return 0.5 * beta_m_width(beta_m)


def beta_m_from_roughness(roughness: float) -> float:
    """The inverse of ``roughness_from_beta_m`` (bisection; beta_m in [0, 1])."""
    target = 2.0 * float(roughness)
    if not 0 < target <= beta_m_width(1.0):
        raise ValueError(f"roughness {roughness} has no Chiang beta_m in (0, 1]")
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if beta_m_width(mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def logistic_scale(beta_n: float) -> float:
    """Chiang eq. 12: the azimuthal logistic's scale s from beta_n."""
    b = float(beta_n)
    return SQRT_PI_OVER_8 * (0.265 * b + 1.194 * b * b + 5.372 * b**22)


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


def mp(cos_i, cos_o, sin_i, sin_o, v):
    """d'Eon et al. 2011 longitudinal lobe (pbrt's Mp), NumPy, for the dual-scattering tables."""
    a = cos_i * cos_o / v
    b = sin_i * sin_o / v
    if v <= 0.1:
        x = np.asarray(a, np.float64)
        big = x > 12
        xs = np.where(big, x, 1.0)
        log_i0 = np.where(big, xs + 0.5 * (-math.log(2 * PI) + np.log(1.0 / xs) + 1.0 / (8.0 * xs)),
                          np.log(_i0(np.where(big, 0.0, x))))
        return np.exp(log_i0 - b - 1.0 / v + 0.6931 + math.log(1.0 / (2.0 * v)))
    return np.exp(-b) * _i0(a) / (math.sinh(1.0 / v) * 2.0 * v)


def _i0(x):
    x = np.asarray(x, np.float64)
    val = np.zeros_like(x)
    term = np.ones_like(x)
    for i in range(10):
        val += term
        term = term * x * x / (4.0 * (i + 1) ** 2)
    return val


def tilt_angles(shift: float) -> np.ndarray:
    """The rotation of theta_o per lobe R, TT, TRT, 3: (-2 alpha, alpha, 4 alpha, 0)."""
    return np.array([-2.0, 1.0, 4.0, 0.0]) * float(shift)


def lobe_shifts(shift: float) -> np.ndarray:
    """Where each lobe peaks in theta_h (Marschner's alpha_p): (alpha, -alpha/2, -2 alpha, 0)."""
    return -0.5 * tilt_angles(shift)


def lobe_widths(roughness: float) -> np.ndarray:
    """Each lobe's standard deviation in theta_h: sqrt(v_p) / 2."""
    return 0.5 * np.sqrt(longitudinal_variances(roughness))


def chiang_lobes(theta_i, theta_o, phi, sigma_a, *, roughness, shift, eta=1.55, beta_n=0.3, n_h=128):
    """The four lobes M_p Nbar_p, each (..., 3), at broadcast angle arrays (for tables)."""
    ti, to, ph = np.broadcast_arrays(*(np.asarray(x, np.float64) for x in (theta_i, theta_o, phi)))
    n_r, n_tt, n_trt, n_3 = azimuthal_average(np.abs(ph), np.abs(to), sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
    v = longitudinal_variances(roughness)
    k = tilt_angles(shift)
    sin_i, cos_i = np.sin(ti), np.cos(ti)
    out = []
    for p, n in enumerate((np.repeat(n_r[..., None], 3, axis=-1), n_tt, n_trt, n_3)):
        m = mp(cos_i, np.abs(np.cos(to + k[p])), sin_i, np.sin(to + k[p]), v[p])
        out.append(m[..., None] * n)
    return out
