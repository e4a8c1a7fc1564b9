"""Marschner et al. 2003 in NumPy (float64), and its lookup textures.

The same equations as marschner.glsl (Hunz 2016 sec. 3.3, Marschner 2003):

    hair_bsdf = cos(theta_i) / cos^2(theta_d) * sum_p M_p(theta_i, theta_o) N_p(theta_d, phi)

* M_p = 1/2 g(beta_p; theta_h - alpha_p), g a unit-integral Gaussian. Marschner's smooth
  cylinder has delta(theta_i + theta_o) = 1/2 delta(theta_h); the paper's (and Hunz's eq. 40)
  g(beta; theta_h - alpha) is unit-integral over theta_h, i.e. integrates to 2 over theta_o,
  which doubles the energy. The 1/2 makes M unit-integral over theta_o.
  alpha_TT = -alpha_R/2, alpha_TRT = -3 alpha_R/2, beta_TT = beta_R/2, beta_TRT = 2 beta_R.
* Energy clamp (on by default, ``energy_clamp``; not in the paper): a lobe shifted by alpha_p
  peaks at theta_o* = 2 alpha_p - theta_i, where the measure cos^2(theta_o) over the model's
  1/cos^2(theta_d) gives it cos^2(2 alpha_p - theta_i) / cos^2(alpha_p - theta_i) times the
  energy of the unshifted lobe: up to +24 % at grazing incidence (sigma_a = 0 albedo 1.24 at
  theta_i = -85 deg, 1.06 at +60 deg with beta_R = 5 deg). M_p is multiplied by
  min(1, cos^2(alpha_p - theta_i) / cos^2(2 alpha_p - theta_i)) so that a shift never adds
  energy (this depends on theta_i only, so it also goes into the M LUT; it breaks strict
  reciprocity, which is why it can be switched off).
* N_p = sum over roots h of phi(p, h) = phi (cubic approximation of Snell's law, solved in
  closed form) of A(p, h) / |2 dphi/dh|, with Bravais indices eta' (perpendicular Fresnel,
  and Snell in the normal plane) and eta'' = eta^2 / eta' (parallel Fresnel).
  A(0) = F, A(1) = (1 - F)^2 T, A(2) = (1 - F)^2 F T^2 (the exit Fresnel equals the entry one
  by reciprocity), T = exp(-sigma_a * 2 cos(gamma_t) / cos(theta_t)), sigma_a per unit radius,
  sin(theta_t) = sin(theta_d) / eta.
* TRT caustics and glints: Hunz Algorithm 1 (after Marschner sec. 4.3), with gamma_c from
  eq. 57, h_c = sin(gamma_c), phi_c = |phi^(2, gamma_c) - 2 pi|, d2phi/dh2 = phi^''(gamma_c)
  / cos^2(gamma_c); for eta' >= 2: h_c = 0, phi_c = 0, dh = dh_M, t = 1 - smoothstep(2, 2 + d_eta', eta').
* |dphi/dh| is floored at 1e-3 and cos(theta_d) at 1e-2 so that every direction is finite.

LUTs (build_marschner_luts): the Nguyen and Donnelly (GPU Gems 2, ch. 23) layout that Hunz
uses, float32 arrays uploaded as RGBA16F with bilinear filtering, sampled at texel centres
(grid point j of n sits at u = (j + 0.5) / n, so the table ends are exact):

* M LUT, (size, size, 4), rows = theta_o, columns = theta_i, both uniform over [-pi/2, pi/2]
  (0.7 deg texels at 256): RGB = M_R, M_TT, M_TRT without the energy clamp, A = cos(theta_d)
  (unused by the shader, kept for the layout). marschner_lut.glsl computes the angles with atan
  (as hair_angles), and evaluates analytically what a bilinear table cannot hold: the
  projection cos(theta_i) / cos^2(theta_d) (a 1/cos^2 ridge at theta_d -> +-90 deg), the energy
  clamp (falls from 1 to 0 within 5 deg of grazing) and N_R (a square-root Fresnel kink at
  total internal reflection of the parallel component, eta'' < 1). ``energy_clamp=True``
  bakes the clamp into M for CPU use only; the GLSL applies it under HAIR_ENERGY_CLAMP.
* N LUT, (size, 2 size, 4): two size x size tiles side by side, rows = cos(theta_d) over
  [0, 1], columns = phi over [0, pi] (uniform in angle: the TT lobe at phi = pi is not
  compressed as it was over cos phi): left tile RGB = N_TT, A = N_R (unused by the shader);
  right tile RGB = N_TRT (the caustic/glint treatment included), A = 0.
Memory at size 256 (ShadingSettings default): 512 KiB (M) + 1 MiB (N). Against the analytic
GLSL, melanin (1.3, 0.3), the quality bench's 20,296 directions: max |error| 0.12 % of the peak,
p95 relative error 0.07 % (was 58 % and 0.15 % over (sin theta, cos phi) with everything
baked); on near-grazing directions (|theta_i|, |theta_o| in [60, 89.5] deg) max 1.2 % of the
peak (the TT/TRT Fresnel kink near theta_d = 80 deg; 9 % with the clamp baked). 128: 0.7 %.
"""
from __future__ import annotations

import math

import numpy as np

PI = math.pi
D_PHI_FLOOR = 1e-3
COS_D_FLOOR = 1e-2


def lobe_params(beta_r: float, alpha_r: float):
    """(alpha, beta) of R, TT, TRT tied as in Hunz Table 1."""
    alpha = np.array([alpha_r, -alpha_r / 2, -3 * alpha_r / 2])
    beta = np.array([beta_r, beta_r / 2, 2 * beta_r])
    return alpha, beta


def gaussian(beta, x):
    return np.exp(-0.5 * (x / beta) ** 2) / (beta * math.sqrt(2 * PI))


def energy_clamp_factor(theta_i, alpha):
    """min(1, cos^2(alpha_p - theta_i) / cos^2(2 alpha_p - theta_i)) per lobe (..., 3)."""
    ti = np.asarray(theta_i, np.float64)[..., None]
    num = np.cos(alpha - ti) ** 2
    den = np.cos(2 * alpha - ti) ** 2
    return np.minimum(1.0, num / np.maximum(den, 1e-12))


def marschner_m(theta_i, theta_o, beta_r, alpha_r, energy_clamp=True):
    """(..., 3): M_R, M_TT, M_TRT = 1/2 g(beta_p; theta_h - alpha_p) [* energy clamp]."""
    alpha, beta = lobe_params(beta_r, alpha_r)
    th = 0.5 * (np.asarray(theta_i) + np.asarray(theta_o))
    m = 0.5 * gaussian(beta, th[..., None] - alpha)
    if energy_clamp:
        m = m * energy_clamp_factor(theta_i, alpha)
    return m


def bravais(eta, cos_d):
    cos_d = np.maximum(cos_d, COS_D_FLOOR)
    sin2 = np.maximum(0.0, 1 - cos_d**2)
    root = np.sqrt(eta * eta - sin2)
    eta1 = root / cos_d            # eta'
    eta2 = eta * eta / eta1        # eta''
    cos_t = root / eta             # cos(theta_t), longitudinal refraction angle
    return eta1, eta2, cos_t


def fresnel(eta1, eta2, cos_g):
    """Unpolarised Fresnel at incidence gamma: perpendicular with eta', parallel with eta''."""
    sin2 = np.maximum(0.0, 1 - cos_g**2)
    ct1 = np.sqrt(np.maximum(0.0, 1 - sin2 / (eta1 * eta1)))
    rs = (cos_g - eta1 * ct1) / np.maximum(cos_g + eta1 * ct1, 1e-30)
    ct2 = np.sqrt(np.maximum(0.0, 1 - sin2 / (eta2 * eta2)))
    rp = (eta2 * cos_g - ct2) / np.maximum(eta2 * cos_g + ct2, 1e-30)
    return 0.5 * (rs * rs + rp * rp)


def solve_roots(p: int, c, phi):
    """Roots gamma_i of phi^(p, gamma) = phi (mod 2 pi) for phi in [0, pi]: (..., 3) and a mask."""
    c = np.asarray(c, np.float64)
    phi = np.asarray(phi, np.float64)
    c, phi = np.broadcast_arrays(c, phi)
    a = -8 * p * c / PI**3
    b = 6 * p * c / PI - 2
    d = p * PI - phi - (2 * PI if p == 2 else 0.0)
    roots = np.full(c.shape + (3,), np.nan)
    if p == 0:
        roots[..., 0] = -d / b
    else:
        P = b / a
        Q = d / a
        disc = (Q / 2) ** 2 + (P / 3) ** 3
        one = disc > 0
        s = np.sqrt(np.maximum(disc, 0))
        sq = np.where(Q >= 0, 1.0, -1.0)
        u = np.cbrt(-Q / 2 - sq * s)
        x1 = u - P / (3 * np.where(u == 0, 1.0, u))
        r = np.sqrt(np.maximum(-P / 3, 0))
        arg = np.clip(-Q / (2 * np.maximum(r, 1e-30) ** 3), -1, 1)
        th = np.arccos(arg) / 3
        for k in range(3):
            xk = 2 * r * np.cos(th - 2 * PI * k / 3)
            roots[..., k] = np.where(one, x1 if k == 0 else np.nan, xk)
    valid = np.abs(roots) <= PI / 2
    return np.where(valid, roots, 0.0), valid


def phi_hat(p, c, g):
    return -8 * p * c / PI**3 * g**3 + (6 * p * c / PI - 2) * g + p * PI


def attenuation(p, h, eta1, eta2, cos_t, sigma_a):
    """A(p, h) (..., 3)."""
    cos_g = np.sqrt(np.maximum(0.0, 1 - h * h))
    f = fresnel(eta1, eta2, cos_g)
    if p == 0:
        return np.repeat(f[..., None], 3, axis=-1)
    sin_gt = h / eta1
    cos_gt = np.sqrt(np.maximum(0.0, 1 - sin_gt**2))
    t = np.exp(-np.asarray(sigma_a) * (2 * cos_gt / cos_t)[..., None])
    if p == 1:
        return ((1 - f) ** 2)[..., None] * t
    return ((1 - f) ** 2 * f)[..., None] * t * t


def marschner_n_p(p, cos_d, phi, sigma_a, eta):
    eta1, eta2, cos_t = bravais(eta, cos_d)
    c = np.arcsin(np.clip(1 / eta1, -1, 1))
    roots, valid = solve_roots(p, c, phi)
    out = 0.0
    for k in range(3):
        g = roots[..., k]
        h = np.sin(g)
        dphi = np.abs(-24 * p * c / PI**3 * g * g + 6 * p * c / PI - 2)
        w = np.cos(g) / (2 * np.maximum(dphi, D_PHI_FLOOR))
        a = attenuation(p, h, eta1, eta2, cos_t, sigma_a)
        out = out + np.where(valid[..., k, None], a * w[..., None], 0.0)
    return out


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0, 1)
    return t * t * (3 - 2 * t)


def marschner_n(cos_d, phi, sigma_a, eta=1.55, glint=0.5, caustic_width=math.radians(15),
                caustic_fade=0.3, caustic_limit=0.5):
    """(N_R (...,), N_TT (..., 3), N_TRT (..., 3)) for phi in [0, pi]."""
    cos_d = np.asarray(cos_d, np.float64)
    phi = np.asarray(phi, np.float64)
    sigma_a = np.asarray(sigma_a, np.float64)
    n_r = marschner_n_p(0, cos_d, phi, sigma_a, eta)[..., 0]
    n_tt = marschner_n_p(1, cos_d, phi, sigma_a, eta)
    n_trt = marschner_n_p(2, cos_d, phi, sigma_a, eta)
    # Hunz Algorithm 1
    eta1, eta2, cos_t = bravais(eta, cos_d)
    c = np.arcsin(np.clip(1 / eta1, -1, 1))
    wc = caustic_width
    below = eta1 < 2
    gc = np.sqrt(np.maximum(12 * c / PI - 2, 0) / (48 * c / PI**3))
    gc = np.where(below, gc, 0.0)
    hc = np.sin(gc)
    d2 = np.abs(96 * c / PI**3 * gc) / np.maximum(np.cos(gc) ** 2, 1e-30)
    dh = np.where(below, np.minimum(caustic_limit, 2 * np.sqrt(2 * wc / np.maximum(d2, 1e-30))), caustic_limit)
    t = np.where(below, 1.0, 1 - _smoothstep(2.0, 2.0 + caustic_fade, eta1))
    phic = np.where(below, np.abs(phi_hat(2, c, gc) - 2 * PI), 0.0)
    g1 = np.exp(-0.5 * ((phi - phic) / wc) ** 2)   # g / g(0)
    g2 = np.exp(-0.5 * ((phi + phic) / wc) ** 2)
    n_trt = n_trt * ((1 - t * g1) * (1 - t * g2))[..., None]
    a2 = attenuation(2, hc, eta1, eta2, cos_t, sigma_a)
    n_trt = n_trt + (t * glint * dh * (g1 + g2) / (wc * math.sqrt(2 * PI)))[..., None] * a2
    return n_r, n_tt, n_trt


def marschner_lobes(theta_i, theta_o, phi, sigma_a, *, eta=1.55, beta_r=math.radians(7.5),
                    alpha_r=math.radians(-5.0), glint=0.5, caustic_width=math.radians(15),
                    caustic_fade=0.3, caustic_limit=0.5, energy_clamp=True):
    """(R (...,), TT (..., 3), TRT (..., 3)) terms of S = sum M_p N_p / cos^2 theta_d (no cos theta_i)."""
    theta_i = np.asarray(theta_i, np.float64)
    theta_o = np.asarray(theta_o, np.float64)
    cos_d = np.maximum(np.cos(0.5 * (theta_o - theta_i)), COS_D_FLOOR)
    m = marschner_m(theta_i, theta_o, beta_r, alpha_r, energy_clamp)
    n_r, n_tt, n_trt = marschner_n(cos_d, phi, sigma_a, eta, glint, caustic_width, caustic_fade, caustic_limit)
    inv = 1 / cos_d**2
    return m[..., 0] * n_r * inv, m[..., 1, None] * n_tt * inv[..., None], m[..., 2, None] * n_trt * inv[..., None]


def marschner_bsdf_angles(theta_i, theta_o, phi, sigma_a, *, specular=1.0, **kw):
    """hair_bsdf (..., 3) = cos(theta_i) * (specular S_R + S_TT + S_TRT)."""
    r, tt, trt = marschner_lobes(theta_i, theta_o, phi, sigma_a, **kw)
    return np.cos(np.asarray(theta_i))[..., None] * (specular * r[..., None] + tt + trt)


def build_marschner_luts(sigma_a, *, eta=1.55, beta_r=math.radians(7.5), alpha_r=math.radians(-5.0),
                         glint=0.5, caustic_width=math.radians(15), caustic_fade=0.3,
                         caustic_limit=0.5, energy_clamp=False, size=128):
    """(m_lut (size, size, 4), n_lut (size, 2 size, 4)) float32; layout in the module docstring.

    Values are clamped to 65000 (they are stored as half floats).
    """
    n = int(size)
    t = np.linspace(-0.5 * PI, 0.5 * PI, n)
    th_o, th_i = np.meshgrid(t, t, indexing="ij")          # rows: theta_o, columns: theta_i
    cos_d = np.maximum(np.cos(0.5 * (th_o - th_i)), COS_D_FLOOR)
    m = marschner_m(th_i, th_o, beta_r, alpha_r, energy_clamp)
    m_lut = np.concatenate([m, cos_d[..., None]], axis=-1)
    cd, phi = np.meshgrid(np.linspace(0.0, 1.0, n), np.linspace(0.0, PI, n), indexing="ij")   # rows: cos_d, cols: phi
    n_r, n_tt, n_trt = marschner_n(cd, phi, sigma_a, eta, glint, caustic_width, caustic_fade, caustic_limit)
    left = np.concatenate([n_tt, n_r[..., None]], axis=-1)
    right = np.concatenate([n_trt, np.zeros_like(n_r)[..., None]], axis=-1)
    n_lut = np.concatenate([left, right], axis=1)
    return (np.minimum(m_lut, 65000.0).astype(np.float32), np.minimum(n_lut, 65000.0).astype(np.float32))
