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
dh = cos gamma_o dgamma_o), ``n_h`` midpoints. 128 x 64 texels, 384 KiB; cached per material by
ShadingSettings. ``azimuthal_grid`` computes it as a matrix product over h (the attenuations
depend on theta_o and h, the logistic on phi - Phi), the logistic without an exponential per
value (``_logistic_block``): ~0.035 s per material on one CPU core (the loop over h it replaced,
kept in tests/shading_tables_v1.py as the golden, took ~0.4 s).

The near field (``ShadingSettings.near_field``): a fibre wider than a pixel shows, in each pixel,
the fibre's function averaged over the part of its width the pixel covers, h in [h0, h1] (pbrt
and Mitsuba evaluate it at each ray's hit h; their pixels average it). ``near_table`` keeps the
running integral C_p(phi, theta_o, gamma) = 1/2 int_{-1}^{sin gamma} A_p N_p dh at 65 layers of
gamma (64 x 32 texels of (phi, theta_o) a tile, 6.4 MB as a 3D RGBA32F texture), and the mean
over [h0, h1] is 2 (C(h1) - C(h0)) / (h1 - h0), the far field when the pixel covers the whole
width. phi is then signed, the light's azimuth past the eye's about -T, with h along
cross(T, V); N_p(-phi, h) = N_p(phi, -h), so phi in [0, pi] suffices. Under a tenth of the
width (fibres over 20 px) the shader evaluates the fibre at the pixel's h instead (chiang.glsl).
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


def _logistic_norm(s: float) -> float:
    """1 / (s x the logistic's mass on [-pi, pi]): the trimmed logistic is this times
    e / (1 + e)^2, e = exp(-|x| / s)."""
    return 1.0 / (s * (1.0 / (1.0 + math.exp(-PI / s)) - 1.0 / (1.0 + math.exp(PI / s))))


def _logistic_block(phi, centre, s, out, tmp):
    """e / (1 + e)^2, e = exp(-|phi - centre wrapped to [-pi, pi]| / s), on the grid phi (P,) x
    centre (T, H), into ``out`` (T, P, H) (``tmp``: scratch of that shape). The trimmed
    logistic is this times ``_logistic_norm(s)``.

    phi in [0, pi] and pi / s <= 600 (every table; else the exponential per value): with the
    centre wrapped to c in [0, 2 pi), d = phi - c lies in (-2 pi, pi] and the wrapped difference
    is d or d + 2 pi, whichever is nearer 0. With q = exp(d / 2s) = exp(phi / 2s) exp(-c / 2s),
    an outer product of two short vectors, e / (1 + e)^2 = 1 / (q + 1/q)^2 (that is
    1 / (2 cosh(x / 2s))^2, even in x), and the nearer candidate is the one of the smaller q + 1/q
    (the other's q is q exp(pi / s)): no exponential per value, and no cancellation."""
    phi = np.asarray(phi, np.float64)
    if phi.min() < 0.0 or phi.max() > PI or PI / s > 600.0:
        x = np.subtract(phi[None, :, None], centre[:, None, :], out=tmp)
        np.multiply(x, 1.0 / (2.0 * PI), out=x)
        np.subtract(x, np.rint(x, out=out), out=x)        # in turns, wrapped to [-1/2, 1/2]
        np.abs(x, out=x)
        np.multiply(x, -2.0 * PI / s, out=x)
        np.exp(x, out=x)
        np.add(x, 1.0, out=out)
        np.square(out, out=out)
        return np.divide(x, out, out=out)
    a = np.exp(phi / (2.0 * s))
    b = np.exp(-np.mod(centre, 2.0 * PI) / (2.0 * s))
    q = np.multiply(a[None, :, None], b[:, None, :], out=out)
    r = np.divide(1.0, q, out=tmp)
    lift = math.exp(PI / s)
    u0 = q + r                                          # 2 cosh(d / 2s)
    np.multiply(q, lift, out=q)
    np.multiply(r, 1.0 / lift, out=r)
    np.add(q, r, out=q)                                 # 2 cosh((d + 2 pi) / 2s)
    np.minimum(u0, q, out=q)
    np.square(q, out=q)
    return np.divide(1.0, q, out=q)


_BLOCK = 1 << 17      # (theta, phi, h) values of the logistic evaluated at once


def azimuthal_grid(phi, theta_o, sigma_a, *, eta=1.55, beta_n=0.3, n_h=256):
    """``azimuthal_average`` on the grid of 1D ``phi`` (P,) x ``theta_o`` (T,): Nbar_R (T, P),
    Nbar_TT, Nbar_TRT (T, P, 3) and Nbar_3 (T, 3) (constant in phi). The h integral is a matrix
    product: per h, the attenuations A_p depend on theta_o alone and the logistic on
    phi - Phi(p, h, theta_o) (Phi(0, h) = -2 gamma_o on h alone)."""
    n_r, n_tt, n_trt, n_3 = azimuthal_bins(phi, theta_o, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h, bins=1)
    return n_r[:, 0], n_tt[:, 0], n_trt[:, 0], n_3[:, 0]


def azimuthal_bins(phi, theta_o, sigma_a, *, eta=1.55, beta_n=0.3, n_h=256, bins=1):
    """``azimuthal_grid``'s integral over h split into ``bins`` equal steps of gamma_o = asin h
    (n_h a multiple of bins): Nbar_R (T, B, P), Nbar_TT, Nbar_TRT (T, B, P, 3), Nbar_3 (T, B, 3),
    each bin's part of 1/2 int A_p N_p dh (their sum over the bins is the far field)."""
    phi = np.asarray(phi, np.float64).reshape(-1)
    theta_o = np.asarray(theta_o, np.float64).reshape(-1)
    sigma_a = np.asarray(sigma_a, np.float64).reshape(3)
    if n_h % bins:
        raise ValueError("n_h must be a multiple of bins")
    k = n_h // bins
    s = logistic_scale(beta_n)
    sin_o, cos_o = np.sin(theta_o), np.maximum(np.cos(theta_o), 1e-6)               # (T,)
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - (sin_o / eta) ** 2))
    etap = np.sqrt(np.maximum(0.0, eta * eta - sin_o * sin_o)) / cos_o
    g = -HALF_PI + (np.arange(n_h) + 0.5) * (PI / n_h)                                 # gamma_o (H,)
    w = 0.5 * np.cos(g) * (PI / n_h) * _logistic_norm(s)      # 1/2 dh = 1/2 cos(gamma) dgamma
    f = _fresnel(cos_o[:, None] * np.cos(g)[None, :], eta)[..., None]                 # (T, H, 1)
    sin_gt = np.sin(g)[None, :] / etap[:, None]
    cos_gt = np.sqrt(np.maximum(0.0, 1.0 - sin_gt * sin_gt))
    gamma_t = np.arcsin(np.clip(sin_gt, -1.0, 1.0))                                    # (T, H)
    T = np.exp(-sigma_a * (2.0 * cos_gt / cos_t[:, None])[..., None])                 # (T, H, 3)
    a1 = (1.0 - f) ** 2 * T
    a2 = a1 * T * f
    a3 = a2 * f * T / (1.0 - T * f)
    n_t, n_p = len(theta_o), len(phi)
    n_3 = np.einsum("bh,tbhc->tbc", w.reshape(bins, k), a3.reshape(n_t, bins, k, 3)) / (2.0 * PI * _logistic_norm(s))
    # R: the logistic of phi + 2 gamma_o, the same for every theta_o
    l_r = _logistic_block(phi, -2.0 * g[None, :], s, *np.empty((2, 1, n_p, n_h)))[0]
    n_r = np.einsum("tbh,pbh->tbp", (f[..., 0] * w).reshape(n_t, bins, k), l_r.reshape(n_p, bins, k))
    n_tt = np.empty((n_t, bins, n_p, 3))
    n_trt = np.empty_like(n_tt)
    step = max(1, _BLOCK // max(1, n_p * n_h))
    buf = np.empty((2, min(step, n_t), n_p, n_h))
    for p, a, out in ((1, a1, n_tt), (2, a2, n_trt)):
        centre = 2.0 * p * gamma_t - 2.0 * g + p * PI                                 # Phi(p) (T, H)
        aw = (a * w[:, None]).reshape(n_t, bins, k, 3)                                 # (T, B, k, 3)
        for t0 in range(0, n_t, step):
            t1 = min(n_t, t0 + step)
            lb = _logistic_block(phi, centre[t0:t1], s, buf[0, :t1 - t0], buf[1, :t1 - t0])   # (t, P, H)
            out[t0:t1] = np.matmul(lb.reshape(t1 - t0, n_p, bins, k).transpose(0, 2, 1, 3), aw[t0:t1])
    return n_r, n_tt, n_trt, n_3


def azimuthal_average(phi, theta_o, sigma_a, *, eta=1.55, beta_n=0.3, n_h=256):
    """(Nbar_R (...,), Nbar_TT (..., 3), Nbar_TRT (..., 3), Nbar_3 (..., 3)) at broadcast
    arrays phi, theta_o (module docstring); ``azimuthal_grid`` on their distinct values, one
    theta_o at a time where they are not a grid."""
    phi, theta_o = np.broadcast_arrays(np.asarray(phi, np.float64), np.asarray(theta_o, np.float64))
    shape = phi.shape
    ph, th = phi.reshape(-1), theta_o.reshape(-1)
    u_t, i_t = np.unique(th, return_inverse=True)
    u_p, i_p = np.unique(ph, return_inverse=True)
    if u_t.size * u_p.size <= 4 * max(1, th.size):                     # a grid, e.g. a table's
        n_r, n_tt, n_trt, n_3 = azimuthal_grid(u_p, u_t, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
        out = n_r[i_t, i_p], n_tt[i_t, i_p], n_trt[i_t, i_p], n_3[i_t]
    else:
        out = np.zeros(th.shape), np.zeros(th.shape + (3,)), np.zeros(th.shape + (3,)), np.zeros(th.shape + (3,))
        for k, t in enumerate(u_t):
            sel = np.nonzero(i_t == k)[0]
            one = azimuthal_grid(ph[sel], t, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
            for o, v in zip(out, one):
                o[sel] = v[0]
    return tuple(o.reshape(shape + o.shape[1:]) for o in out)


def azimuthal_table(sigma_a, *, eta=1.55, beta_n=0.3, n_phi=128, n_theta=64, n_h=256) -> np.ndarray:
    """(n_theta, 3 n_phi, 4) float32 texture data (module docstring)."""
    if int(n_phi) < 4 or int(n_theta) < 4:
        raise ValueError("the Chiang table needs at least 4 x 4 texels")
    phi = np.linspace(0.0, PI, int(n_phi))
    theta = np.linspace(0.0, HALF_PI, int(n_theta))
    n_r, n_tt, n_trt, n_3 = azimuthal_grid(phi, theta, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
    out = np.zeros((int(n_theta), TILES * int(n_phi), 4))
    out[:, :n_phi, :3] = n_tt
    out[:, :n_phi, 3] = n_r
    out[:, n_phi:2 * n_phi, :3] = n_trt
    out[:, 2 * n_phi:, :3] = n_3[:, None, :]          # constant along phi
    if not np.isfinite(out).all():
        raise FloatingPointError("non-finite Chiang table")
    return out.astype(np.float32)


def near_table(sigma_a, *, eta=1.55, beta_n=0.3, n_phi=64, n_theta=32, bins=64, n_h=256) -> np.ndarray:
    """(bins + 1, n_theta, 3 n_phi, 4) float32 texture data of ``hair_chiang_c``: the near
    field's running integral C_p(phi, theta_o, gamma) = 1/2 int_{-1}^{sin gamma} A_p N_p dh at
    gamma_o = -pi/2 + pi j / bins (layer j; layer 0 zero, the last the far field, ``azimuthal_table``'s
    values), in its tiles and texel grid (module docstring). The mean over h in [h0, h1] is
    2 (C(h1) - C(h0)) / (h1 - h0): what a pixel covering that part of a fibre shows."""
    if int(n_phi) < 4 or int(n_theta) < 4 or int(bins) < 2:
        raise ValueError("the near-field table needs at least 4 x 4 texels and 2 steps")
    phi = np.linspace(0.0, PI, int(n_phi))
    theta = np.linspace(0.0, HALF_PI, int(n_theta))
    n_r, n_tt, n_trt, n_3 = azimuthal_bins(phi, theta, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h, bins=int(bins))
    out = np.zeros((int(bins) + 1, int(n_theta), TILES * int(n_phi), 4))
    out[1:, :, :n_phi, :3] = np.cumsum(n_tt, axis=1).transpose(1, 0, 2, 3)
    out[1:, :, :n_phi, 3] = np.cumsum(n_r, axis=1).transpose(1, 0, 2)
    out[1:, :, n_phi:2 * n_phi, :3] = np.cumsum(n_trt, axis=1).transpose(1, 0, 2, 3)
    out[1:, :, 2 * n_phi:, :3] = np.cumsum(n_3, axis=1).transpose(1, 0, 2)[:, :, None, :]
    if not np.isfinite(out).all():
        raise FloatingPointError("non-finite Chiang near-field table")
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
