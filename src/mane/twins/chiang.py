"""NumPy twin of the Chiang et al. 2016 hair fibre (src/mane/render/shading/chiang.glsl), written
from the paper and pbrt-v4's HairBxDF (Pharr, Jakob, Humphreys, "Physically Based Rendering",
4th ed., sec. 9.9 / pbrt-v3 "The Implementation of a Hair Scattering Model"), float64, used by
tests only. The far-field fibre BSDF averaged over the offset h in [-1, 1] (a ray meets a fibre
at a uniformly distributed h):

    f(w_o, w_i) |cos| = 1/2 int_{-1}^{1} sum_{p=0}^{3} M_p(theta_i, theta_o^p) A_p(theta_o, h) N_p(phi; h) dh

(pbrt's ``fsum``: the reflected radiance is fsum * L_i dw_i; mane's hair_bsdf is this with
w_o = V, the eye, w_i = L, the light.)

* Longitudinal (d'Eon et al. 2011, eq. 7; pbrt ``Mp``), variance v:
      M(v) = csch(1/v) / (2 v) exp(-sin_i sin_o / v) I0(cos_i cos_o / v)
  for v <= 0.1 in log form (pbrt's low-variance branch):
      M(v) = exp(log I0(a) - b - 1/v + ln 2 + ln(1 / (2 v))),  a = cos_i cos_o / v, b = sin_i sin_o / v
  with I0 the modified Bessel function (10-term series; log I0(x) ~ x + (-ln 2pi + ln(1/x) + 1/(8x))/2
  for x > 12), v_0 = (2 roughness)^2 (mane's roughness is the R lobe's standard deviation in
  theta_h, Marschner's beta_R, so 2 beta_R in theta_o; Chiang's beta_m gives
  sqrt(v_0) = 0.726 beta_m + 0.812 beta_m^2 + 3.7 beta_m^20, eq. 7), v_1 = v_0 / 4, v_2 = v_3 = 4 v_0.
* Cuticle tilt alpha (pbrt ``sin2kAlpha``): theta_o is rotated per lobe before M_p:
      R: theta_o - 2 alpha,  TT: theta_o + alpha,  TRT: theta_o + 4 alpha,  p = 3: unshifted
  (cos taken in absolute value). mane's ``shift`` is alpha (Marschner's alpha_R: the R lobe
  peaks at theta_h = alpha).
* Attenuation (Chiang eq. 3-4; pbrt ``Ap``): f = Fresnel(cos theta_o sqrt(1 - h^2), eta)
  (unpolarised dielectric), T = exp(-sigma_a 2 cos gamma_t / cos theta_t),
      A_0 = f, A_1 = (1 - f)^2 T, A_2 = A_1 T f, A_3 = A_2 f T / (1 - T f)
  sin theta_t = sin theta_o / eta, eta' = sqrt(eta^2 - sin^2 theta_o) / cos theta_o (Bravais),
  sin gamma_t = h / eta'.
* Azimuthal (Chiang eq. 8-12; pbrt ``Np``): Phi(p, h) = 2 p gamma_t - 2 gamma_o + p pi,
  gamma_o = asin h; N_p = trimmed logistic of (phi - Phi) wrapped to [-pi, pi], scale
      s = sqrt(pi / 8) (0.265 beta_n + 1.194 beta_n^2 + 5.372 beta_n^22);  N_3 = 1 / (2 pi).
* phi = phi_i - phi_o, the azimuth between L and V in the normal plane.
"""
from __future__ import annotations

import math

import numpy as np

SQRT_PI_OVER_8 = math.sqrt(math.pi / 8.0)


def variances(roughness):
    v0 = (2.0 * float(roughness)) ** 2
    return np.array([v0, 0.25 * v0, 4.0 * v0, 4.0 * v0])


def beta_m_variance(beta_m):
    """Chiang eq. 7 (pbrt): v_0 from Chiang's longitudinal roughness beta_m in [0, 1]."""
    return (0.726 * beta_m + 0.812 * beta_m**2 + 3.7 * beta_m**20) ** 2


def logistic_scale(beta_n):
    return SQRT_PI_OVER_8 * (0.265 * beta_n + 1.194 * beta_n**2 + 5.372 * beta_n**22)


def i0(x):
    x = np.asarray(x, np.float64)
    val = np.zeros_like(x)
    x2i = np.ones_like(x)
    fact = 1.0
    for i in range(10):
        if i > 1:
            fact *= i
        val += x2i / (4.0**i * fact * fact)
        x2i = x2i * x * x
    return val


def log_i0(x):
    x = np.asarray(x, np.float64)
    big = x > 12
    xs = np.where(big, x, 1.0)
    return np.where(big, x + 0.5 * (-math.log(2 * math.pi) + np.log(1.0 / xs) + 1.0 / (8.0 * xs)),
                    np.log(i0(np.where(big, 0.0, x))))


def mp(cos_i, cos_o, sin_i, sin_o, v):
    a = cos_i * cos_o / v
    b = sin_i * sin_o / v
    if v <= 0.1:
        return np.exp(log_i0(a) - b - 1.0 / v + 0.6931 + math.log(1.0 / (2.0 * v)))
    return np.exp(-b) * i0(a) / (math.sinh(1.0 / v) * 2.0 * v)


def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance from outside (cos_i >= 0) into a medium of index eta."""
    cos_i = np.clip(cos_i, 0.0, 1.0)
    sin2_t = (1.0 - cos_i**2) / eta**2
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return 0.5 * (r_par**2 + r_perp**2)


def attenuation(cos_o, sin_o, h, sigma_a, eta):
    """A_p (p = 0..3), each (..., 3), at the eye's inclination and offset h."""
    cos_o = np.asarray(cos_o, np.float64)
    f = fresnel_dielectric(cos_o * np.sqrt(np.maximum(0.0, 1.0 - h * h)), eta)
    sin_t = sin_o / eta
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t**2))
    etap = np.sqrt(np.maximum(0.0, eta * eta - sin_o**2)) / np.maximum(cos_o, 1e-12)
    sin_gt = h / etap
    cos_gt = np.sqrt(np.maximum(0.0, 1.0 - sin_gt**2))
    T = np.exp(-np.asarray(sigma_a)[None, :] * (2.0 * cos_gt / cos_t)[..., None])
    f3 = f[..., None]
    a0 = np.repeat(f3, 3, axis=-1)
    a1 = (1.0 - f3) ** 2 * T
    a2 = a1 * T * f3
    a3 = a2 * f3 * T / (1.0 - T * f3)
    return [a0, a1, a2, a3], np.arcsin(np.clip(sin_gt, -1, 1))


def trimmed_logistic(x, s):
    x = np.abs(x)
    e = np.exp(-x / s)
    norm = 1.0 / (1.0 + math.exp(-math.pi / s)) - 1.0 / (1.0 + math.exp(math.pi / s))
    return e / (s * (1.0 + e) ** 2) / norm


def n_p(phi, p, s, gamma_o, gamma_t):
    dphi = phi - (2.0 * p * gamma_t - 2.0 * gamma_o + p * math.pi)
    dphi = np.mod(dphi + math.pi, 2.0 * math.pi) - math.pi
    return trimmed_logistic(dphi, s)


def tilted(sin_o, cos_o, alpha, p):
    """(sin, |cos|) of theta_o rotated for lobe p (module docstring)."""
    k = {0: -2.0, 1: 1.0, 2: 4.0}.get(p, 0.0) * alpha
    s = sin_o * math.cos(k) + cos_o * math.sin(k)
    c = cos_o * math.cos(k) - sin_o * math.sin(k)
    return s, np.abs(c)


def fibre(theta_i, theta_o, phi, sigma_a, *, roughness, shift, beta_n, eta=1.55, n_h=256, lobes=False):
    """f |cos| (..., 3) at angles (arrays of one shape), averaged over n_h midpoint offsets h.
    With ``lobes=True`` the four lobes separately, (4, ..., 3)."""
    hs = -1.0 + (np.arange(n_h) + 0.5) * (2.0 / n_h)
    out = sum(fibre_near(theta_i, theta_o, phi, h, sigma_a, roughness=roughness, shift=shift, beta_n=beta_n, eta=eta,
                         lobes=True) for h in hs) / n_h
    return out if lobes else out.sum(axis=0)


def fibre_near(theta_i, theta_o, phi, h, sigma_a, *, roughness, shift, beta_n, eta=1.55, lobes=False):
    """The near field: f |cos| (..., 3) of the fibre met at offset h in [-1, 1] (pbrt's and
    Mitsuba's evaluation at a ray's hit), phi = phi_i - phi_o signed in (-pi, pi]; its mean over
    h is ``fibre``. With ``lobes=True`` the four lobes, (4, ..., 3)."""
    ti, to, ph = np.broadcast_arrays(np.asarray(theta_i, np.float64), np.asarray(theta_o, np.float64),
                                     np.asarray(phi, np.float64))
    h = np.broadcast_to(np.asarray(h, np.float64), ti.shape)
    sin_i, cos_i = np.sin(ti), np.cos(ti)
    sin_o, cos_o = np.sin(to), np.cos(to)
    v = variances(roughness)
    s = logistic_scale(beta_n)
    A, gamma_t = attenuation(cos_o, sin_o, h, sigma_a, eta)
    gamma_o = np.arcsin(np.clip(h, -1.0, 1.0))
    out = np.zeros((4,) + ti.shape + (3,))
    for p in range(4):
        so, co = tilted(sin_o, cos_o, shift, p)
        m = mp(cos_i, co, sin_i, so, v[p])
        n = n_p(ph, p, s, gamma_o, gamma_t) if p < 3 else 1.0 / (2.0 * math.pi)
        out[p] = (m * n)[..., None] * A[p]
    return out if lobes else out.sum(axis=0)


def _vec_angles(T, V, L):
    si = np.clip(np.sum(T * L, -1), -1, 1)
    so = np.clip(np.sum(T * V, -1), -1, 1)
    lp = L - si[:, None] * T
    vp = V - so[:, None] * T
    ci = np.minimum(np.linalg.norm(lp, axis=-1), 1.0)
    co = np.minimum(np.linalg.norm(vp, axis=-1), 1.0)
    x = np.sum(vp * lp, -1)
    y = np.linalg.norm(np.cross(vp, lp), axis=-1)
    phi = np.where(np.abs(x) + y > 1e-12, np.arctan2(y, x), math.pi / 2)
    return np.arctan2(si, np.maximum(ci, 1e-30)), np.arctan2(so, np.maximum(co, 1e-30)), phi


def signed_angles(T, V, L):
    """(theta_i, theta_o, phi) for the near field: phi the light's azimuth past the eye's about
    -T, signed, in (-pi, pi] (its sine along -cross(T, V)); with h along cross(T, V) the
    convention of pbrt's and Mitsuba's phi_i - phi_o (chiang.glsl's hair_chiang_signed_phi)."""
    T, V, L = (np.asarray(x, np.float64) for x in (T, V, L))
    ti, to, _ = _vec_angles(T, V, L)
    lp = L - np.sum(T * L, -1)[:, None] * T
    vp = V - np.sum(T * V, -1)[:, None] * T
    return ti, to, np.arctan2(-np.sum(lp * np.cross(T, V), -1), np.sum(lp * vp, -1))


def near_mean(theta_i, theta_o, phi, h0, h1, sigma_a, *, roughness, shift, beta_n, eta=1.55, steps=200):
    """``fibre_near`` averaged over h in [h0, h1] (arrays of one shape), by ``steps`` midpoint steps
    of gamma = asin h (dh = cos gamma dgamma): what a pixel covering that part of a fibre shows."""
    g0, g1 = np.arcsin(np.clip(h0, -1.0, 1.0)), np.arcsin(np.clip(h1, -1.0, 1.0))
    acc = 0.0
    for k in range(int(steps)):
        g = g0 + (g1 - g0) * (k + 0.5) / steps
        acc = acc + fibre_near(theta_i, theta_o, phi, np.sin(g), sigma_a, roughness=roughness, shift=shift,
                               beta_n=beta_n, eta=eta) * (np.cos(g) * (g1 - g0) / steps)[..., None]
    return acc / np.maximum(np.sin(g1) - np.sin(g0), 1e-12)[..., None]


def chiang(T, V, L, m, n_h=256):
    """hair_bsdf of HAIR_MODEL_CHIANG for unit T, V, L (N, 3) and the material dict of
    shading.material() (plus "beta_n")."""
    ti, to, phi = _vec_angles(np.asarray(T, float), np.asarray(V, float), np.asarray(L, float))
    return fibre(ti, to, phi, m["sigma_a"], roughness=m["roughness"], shift=m["shift"], beta_n=m["beta_n"],
                 eta=m["eta"], n_h=n_h) * np.array([1.0, 1.0, 1.0])


def directional_albedo(theta_o, sigma_a, *, n_theta=256, n_phi=256, **kw):
    """int f |cos| dw_i over the sphere of light directions (pbrt's white furnace: 1 for sigma_a = 0)."""
    ti = (np.arange(n_theta) + 0.5) / n_theta * math.pi - math.pi / 2
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * math.pi - math.pi
    TI, PH = np.meshgrid(ti, ph, indexing="ij")
    f = fibre(TI, np.full_like(TI, theta_o), PH, sigma_a, **kw)
    w = np.cos(TI) * (math.pi / n_theta) * (2 * math.pi / n_phi)
    return (f * w[..., None]).sum(axis=(0, 1))
