"""Zinke, Yuksel, Weber and Keyser 2008, "Dual Scattering Approximation for Fast Multiple
Scattering in Hair": NumPy precomputation of the per-material tables and their lookup texture.

Everything is integrated from the single-scattering lobes of the material's fibre model:
``model="marschner"`` (also for the colour-driven models): Marschner's lobes of luts.py (the
same S_p = M_p N_p / cos^2 theta_d that hair_bsdf uses, per colour channel, with the
material's sigma_a, eta, roughness, shift, glint, caustic constants, energy clamp and
``specular`` on R); ``model="chiang"``: the four lobes of chiang.py (R, TT, TRT, TRRT+), see
"Chiang's fibre" below.

Notation: theta_i is the inclination of the light (the paper's theta_d of omega_d, the
direction towards the light; Sadeghi and Tamstorf 2010 point out that it is the light's
inclination, not Marschner's difference angle), theta_o the inclination of the outgoing
direction, phi in [0, pi] the relative azimuth (phi = 0 back towards the light, pi straight
through). Forward hemisphere Omega_f: phi in [pi/2, pi]; backward Omega_b: phi in [0, pi/2]
(each counted twice, phi and -phi). Per colour channel, per lobe p in {R, TT, TRT}:

    I_f^p(theta_i) = int_{Omega_f} S_p(theta_i, theta_o, phi) cos(theta_o) dw_o     dw_o = cos theta_o dtheta_o dphi
    I_b^p(theta_i) = int_{Omega_b} S_p ...

* Eq. 6 / Eq. 11 (average forward / backward scattering attenuation):
      a_f = sum_p I_f^p,  a_b = sum_p I_b^p.
  The paper prints a 1/pi in front of these integrals for its BCSDF normalisation; with
  mane's normalisation (hair_bsdf's directional albedo int S cos theta_o dw_o, which
  test_marschner_albedo_never_above_one checks is <= 1) the plain integrals are the energy
  fractions, so a_f + a_b is the directional albedo of the single scattering.
* Average longitudinal shift and variance of the forward / backward scattered light (the
  lobe parameters weighted by each lobe's share of the energy scattered into that
  hemisphere; alpha_p, beta_p are Marschner's, in theta_h, Hunz Table 1):
      alpha_f = sum_p alpha_p I_f^p / a_f,   beta_f^2 = sum_p beta_p^2 I_f^p / a_f    (b likewise)
* Eq. 12-14, local back-scattering attenuation (one and three backward scatterings with
  any number of forward ones in between, a_f and a_b at the light's theta_i):
      A_1 = a_b a_f^2 / (1 - a_f^2),   A_3 = a_b^3 a_f^2 / (1 - a_f^2)^3,   A_b = A_1 + A_3
* Eq. 16, average back-scattering shift:
      Delta_b = alpha_b (1 - 2 a_b^2 / (1 - a_f^2)^2)
              + alpha_f (2 (1 - a_f^2)^2 + 4 a_f^2 a_b^2) / (1 - a_f^2)^3
* Eq. 17, average back-scattering standard deviation (as printed in the paper):
      sigma_b = (1 + d_b a_f^2) (a_b sqrt(2 beta_f^2 + beta_b^2) + a_b^3 sqrt(2 beta_f^2 + 3 beta_b^2))
                / (a_b + a_b^3 (2 beta_f + 3 beta_b))
  stored as sigma_b^2 (d_b, the back-scattering density factor, is baked in here).
* Eq. 25 / Algorithm 1, azimuthal functions for the forward-scattered (indirect) light:
  N_p averaged over the forward half,
      N_p^G(theta_d) = 2/pi int_{pi/2}^{pi} N_p(cos theta_d, phi) dphi
  over Marschner's difference angle |theta_d| = |theta_o - theta_i| / 2 (N_R is colourless).

Chiang's fibre (``model="chiang"``): M_p is normalised (int M_p cos theta_i dtheta_i = 1) and
the azimuthal table Nbar_p(phi, theta_o) (chiang.py) carries the attenuation, so with the eye at
theta the energy each lobe gathers from the forward / backward half of the light directions is
      I_f^p(theta) = 2 int_{pi/2}^{pi} Nbar_p(phi, theta) dphi,   I_b^p = 2 int_0^{pi/2} Nbar_p dphi
(pbrt's white-furnace integral split by hemisphere: a_f + a_b = sum_p Abar_p <= 1 exactly); by
the model's reciprocity this is also the energy light from theta scatters into each half, so it
serves as a_f(theta_i), a_b(theta_i). The lobes peak at theta_h = (alpha, -alpha/2, -2 alpha, 0)
with widths (1, 1/2, 2, 2) roughness (chiang.lobe_shifts / lobe_widths). The global azimuthal
functions are the averages over the whole circle,
      N^G_p(theta_o) = 1/pi int_0^pi Nbar_p(phi, theta_o) dphi = (I_f^p + I_b^p)(theta_o) / (2 pi),
over the eye's |theta_o| (Nbar depends on theta_o, not theta_d), not Zinke's forward-half
average 2/pi int_{pi/2}^{pi} N_p dphi (Eq. 25). The forward-scattered light reaches a fibre from
azimuths spread around the light's; a constant N^G must then integrate over the circle to the
lobe's energy, 2 pi N^G_p = Abar_p (what the fibre scatters of light from any one direction).
Zinke's value is the spread-out light's average only with the eye straight behind the light
(phi = pi); used at every phi it gives TT twice its energy and R and TRT (mostly backward) almost
none: Sintel blond, where TT carries most of a_f, rendered 1.25x the path tracer and 2-3x its
multiple scattering in the hair's shadowed half (docs/quality.md). (Marschner's tables below
keep Eq. 25.)

Guards (not in the paper): a_f and a_b are clamped to [0, 1] before use, 1 - a_f^2 to >= 1e-4,
the denominator of sigma_b to >= 1e-12 (a_b = 0 gives sigma_b = 0 there; A_b is 0 too), and
Delta_b to [-pi/2, pi/2].

Lookup texture (``build_dual_lut``): a (9, size) RGBA32F 2D texture, 9 rows, ``size`` texels
per row (default 64, 7 KiB), linear filtering in x, sampled at texel centres with the grid
point j of n at x = (j + 0.5) / n so that the table ends are exact, and rows fetched at their
centres (texelFetch of the row, no filtering across rows):

    rows over theta_i in [-pi/2, pi/2] (grid theta_j = -pi/2 + pi j / (size - 1)):
      0  A_b.rgb                 3  a_f.rgb
      1  Delta_b.rgb             4  beta_f^2.rgb
      2  sigma_b^2.rgb            8  I_f^TT.rgb (Chiang; 0 for Marschner)
    rows over |theta_d| in [0, pi/2] (grid pi/2 j / (size - 1)):
      5  N^G_TT.rgb, N^G_R in a  6  N^G_TRT.rgb  7  N^G_TRRT+.rgb (Chiang; 0 for Marschner)
    (Chiang: rows 5-7 over |theta_o| in [0, pi/2].) Row 8: the forward-scattered energy TT
    carries (``forward_tt``), per channel, the part of a_f that keeps the beam's direction, for
    the diffuse part of the scattered light. alpha = 0 elsewhere.

Integration: midpoint rule, ``n_theta_o`` x ``n_phi`` points per theta_i (default 192 x 96;
against 512 x 256: a_f, a_b within 1.4e-3 absolute, A_b within 0.3 % of its peak, worst at
grazing theta_i), ``n_phi_g`` points for N^G. a_f + a_b equals hair_bsdf's directional albedo
(checked against an independent integration). Cached per material by
ShadingSettings.dual_tables(). Chiang's tables take ~0.03 s on one CPU core (one
``chiang.azimuthal_grid`` for both theta grids: |theta_i| of the linspace over [-pi/2, pi/2] lies
on the one over [0, pi/2]); Marschner's 1-2 s (the lobes of luts.py per theta_i).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .luts import lobe_params, marschner_lobes, marschner_n

PI = math.pi
HALF_PI = 0.5 * math.pi
LUT_ROWS = 9
ROW_AB, ROW_DELTA_B, ROW_SIGMA_B2, ROW_AF, ROW_BETA_F2, ROW_NG0, ROW_NG1, ROW_NG3, ROW_TT = range(LUT_ROWS)

# Zinke 2008 sec. 4: density factors d_f, d_b of human hair are ~0.6-0.8; 0.7 in the paper.
DENSITY_FRONT = 1.0   # mane's default (ShadingSettings.dual_density_front says why)
DENSITY_BACK = 1.0    # mane's default (ShadingSettings.dual_density_back says why)


@dataclass(frozen=True)
class DualTables:
    """Dual-scattering tables of one material; (size,) or (size, 3) float64 arrays.

    theta: the theta_i grid; theta_d: the |theta_d| grid of the N^G rows.
    """

    theta: np.ndarray
    a_f: np.ndarray
    a_b: np.ndarray
    alpha_f: np.ndarray
    alpha_b: np.ndarray
    beta_f2: np.ndarray
    beta_b2: np.ndarray
    A_b: np.ndarray
    delta_b: np.ndarray
    sigma_b2: np.ndarray
    theta_d: np.ndarray
    ng_r: np.ndarray
    ng_tt: np.ndarray
    ng_trt: np.ndarray
    lobe_f: np.ndarray    # (size, lobes, 3 colours): I_f^p (3 lobes Marschner, 4 Chiang)
    lobe_b: np.ndarray    # (size, lobes, 3 colours): I_b^p
    ng_trrt: np.ndarray = None   # (size, 3): Chiang's TRRT+ N^G (zeros for Marschner)


def hemisphere_integrals(theta_i, sigma_a, *, specular=1.0, n_theta_o=192, n_phi=96, **marschner_kw):
    """(I_f, I_b), each (len(theta_i), 3 lobes R/TT/TRT, 3 colours): the energy each lobe
    scatters into the forward / backward hemisphere (see the module docstring)."""
    if n_phi % 2:
        raise ValueError("n_phi must be even (the hemispheres split at phi = pi/2)")
    theta_i = np.atleast_1d(np.asarray(theta_i, np.float64))
    to = (np.arange(n_theta_o) + 0.5) / n_theta_o * PI - HALF_PI
    ph = (np.arange(n_phi) + 0.5) / n_phi * PI
    w_o = np.cos(to) ** 2 * (PI / n_theta_o)            # cos(theta_o) dw_o / dphi
    w_phi = 2.0 * PI / n_phi                             # phi and -phi
    back = ph < HALF_PI
    out_f = np.zeros((theta_i.size, 3, 3))
    out_b = np.zeros((theta_i.size, 3, 3))
    TO, PH = np.meshgrid(to, ph, indexing="ij")
    for k, ti in enumerate(theta_i):
        r, tt, trt = marschner_lobes(np.full_like(TO, ti), TO, PH, sigma_a, **marschner_kw)
        lobes = np.stack([np.repeat(specular * r[..., None], 3, axis=-1), tt, trt], axis=-2)
        per_phi = np.einsum("opkc,o->pkc", lobes, w_o) * w_phi      # (n_phi, lobe, colour)
        out_f[k] = per_phi[~back].sum(axis=0)
        out_b[k] = per_phi[back].sum(axis=0)
    return out_f, out_b


def back_scattering(a_f, a_b, alpha_f, alpha_b, beta_f2, beta_b2, d_b=DENSITY_BACK):
    """(A_b, Delta_b, sigma_b^2): Zinke 2008 eqs. 12-14, 16, 17 (module docstring)."""
    af = np.clip(a_f, 0.0, 1.0)
    ab = np.clip(a_b, 0.0, 1.0)
    af2, ab2 = af * af, ab * ab
    om = np.maximum(1.0 - af2, 1e-4)
    A1 = ab * af2 / om
    A3 = ab * ab2 * af2 / om**3
    A_b = A1 + A3
    delta_b = alpha_b * (1.0 - 2.0 * ab2 / om**2) + alpha_f * (2.0 * om**2 + 4.0 * af2 * ab2) / om**3
    delta_b = np.clip(delta_b, -HALF_PI, HALF_PI)
    bf = np.sqrt(np.maximum(beta_f2, 0.0))
    bb = np.sqrt(np.maximum(beta_b2, 0.0))
    num = (1.0 + d_b * af2) * (ab * np.sqrt(2 * beta_f2 + beta_b2) + ab * ab2 * np.sqrt(2 * beta_f2 + 3 * beta_b2))
    den = ab + ab * ab2 * (2 * bf + 3 * bb)
    sigma_b = np.where(den > 1e-12, num / np.maximum(den, 1e-12), 0.0)
    return A_b, delta_b, sigma_b * sigma_b


def azimuthal_forward_average(cos_d, sigma_a, *, n_phi=256, eta=1.55, glint=0.5,
                              caustic_width=math.radians(15), caustic_fade=0.3, caustic_limit=0.5):
    """(N^G_R (...,), N^G_TT (..., 3), N^G_TRT (..., 3)): 2/pi int_{pi/2}^{pi} N_p dphi."""
    cos_d = np.asarray(cos_d, np.float64)
    ph = HALF_PI + (np.arange(n_phi) + 0.5) / n_phi * HALF_PI
    CD, PH = np.meshgrid(cos_d, ph, indexing="ij")
    n_r, n_tt, n_trt = marschner_n(CD, PH, sigma_a, eta, glint, caustic_width, caustic_fade, caustic_limit)
    # (2 / pi) * (pi / 2) / n_phi * sum = mean over the midpoints
    return n_r.mean(axis=1), n_tt.mean(axis=1), n_trt.mean(axis=1)


def chiang_hemisphere_integrals(theta, sigma_a, *, eta=1.55, beta_n=0.3, specular=1.0, n_phi=128, n_h=128):
    """(I_f, I_b), each (len(theta), 4 lobes, 3 colours), for Chiang's fibre with the eye at
    ``theta`` (module docstring); the azimuthal table once per distinct |theta| (to 1e-12 rad)."""
    from .chiang import azimuthal_grid

    theta = np.atleast_1d(np.asarray(theta, np.float64))
    ph = (np.arange(n_phi) + 0.5) / n_phi * PI
    u, inv = np.unique(np.round(np.abs(theta), 12), return_inverse=True)
    n_r, n_tt, n_trt, n_3 = azimuthal_grid(ph, u, sigma_a, eta=eta, beta_n=beta_n, n_h=n_h)
    w = 2.0 * PI / n_phi                                  # phi and -phi
    back = ph < HALF_PI
    out = []
    for half in (~back, back):
        lobes = [np.repeat(specular * n_r[:, half].sum(axis=1)[:, None], 3, axis=1),
                 n_tt[:, half].sum(axis=1), n_trt[:, half].sum(axis=1), half.sum() * n_3]
        out.append((np.stack(lobes, axis=1) * w)[inv.reshape(-1)])
    return out[0], out[1]


def precompute_dual(sigma_a, *, eta=1.55, beta_r=math.radians(7.5), alpha_r=math.radians(-5.0),
                    glint=0.5, caustic_width=math.radians(15), caustic_fade=0.3, caustic_limit=0.5,
                    energy_clamp=True, specular=1.0, d_b=DENSITY_BACK, size=64, n_theta_o=192,
                    n_phi=96, n_phi_g=256, model="marschner", beta_n=0.3) -> DualTables:
    """The dual-scattering tables of a material (module docstring), over ``size`` theta_i.
    ``model``: "marschner" or "chiang" (then glint, the caustic constants and energy_clamp
    are not used, beta_n is)."""
    n = int(size)
    if n < 4:
        raise ValueError("size must be >= 4")
    sigma_a = np.asarray(sigma_a, np.float64).reshape(3)
    if model == "chiang":
        return _precompute_dual_chiang(sigma_a, n, eta=eta, roughness=beta_r, shift=alpha_r, beta_n=beta_n,
                                       specular=specular, d_b=d_b)
    if model != "marschner":
        raise ValueError(f"dual scattering tables for 'marschner' or 'chiang', not {model!r}")
    kw = dict(eta=eta, beta_r=beta_r, alpha_r=alpha_r, glint=glint, caustic_width=caustic_width,
              caustic_fade=caustic_fade, caustic_limit=caustic_limit, energy_clamp=energy_clamp)
    theta = np.linspace(-HALF_PI, HALF_PI, n)
    I_f, I_b = hemisphere_integrals(theta, sigma_a, specular=specular, n_theta_o=n_theta_o, n_phi=n_phi, **kw)
    alpha, beta = lobe_params(beta_r, alpha_r)
    a_f = I_f.sum(axis=1)
    a_b = I_b.sum(axis=1)
    safe_f = np.maximum(a_f, 1e-30)
    safe_b = np.maximum(a_b, 1e-30)
    alpha_f = np.einsum("tpc,p->tc", I_f, alpha) / safe_f
    alpha_b = np.einsum("tpc,p->tc", I_b, alpha) / safe_b
    beta_f2 = np.einsum("tpc,p->tc", I_f, beta**2) / safe_f
    beta_b2 = np.einsum("tpc,p->tc", I_b, beta**2) / safe_b
    A_b, delta_b, sigma_b2 = back_scattering(a_f, a_b, alpha_f, alpha_b, beta_f2, beta_b2, d_b)
    theta_d = np.linspace(0.0, HALF_PI, n)
    ng_r, ng_tt, ng_trt = azimuthal_forward_average(
        np.cos(theta_d), sigma_a, n_phi=n_phi_g, eta=eta, glint=glint, caustic_width=caustic_width,
        caustic_fade=caustic_fade, caustic_limit=caustic_limit)
    return DualTables(theta=theta, a_f=a_f, a_b=a_b, alpha_f=alpha_f, alpha_b=alpha_b, beta_f2=beta_f2,
                      beta_b2=beta_b2, A_b=A_b, delta_b=delta_b, sigma_b2=sigma_b2, theta_d=theta_d,
                      ng_r=ng_r, ng_tt=ng_tt, ng_trt=ng_trt, lobe_f=I_f, lobe_b=I_b,
                      ng_trrt=np.zeros_like(ng_tt))


def _lobe_averages(I_f, I_b, alpha, beta):
    a_f = I_f.sum(axis=1)
    a_b = I_b.sum(axis=1)
    safe_f = np.maximum(a_f, 1e-30)
    safe_b = np.maximum(a_b, 1e-30)
    return (a_f, a_b, np.einsum("tpc,p->tc", I_f, alpha) / safe_f, np.einsum("tpc,p->tc", I_b, alpha) / safe_b,
            np.einsum("tpc,p->tc", I_f, beta**2) / safe_f, np.einsum("tpc,p->tc", I_b, beta**2) / safe_b)


def _precompute_dual_chiang(sigma_a, n, *, eta, roughness, shift, beta_n, specular, d_b) -> DualTables:
    from .chiang import lobe_shifts, lobe_widths

    theta = np.linspace(-HALF_PI, HALF_PI, n)
    theta_o = np.linspace(0.0, HALF_PI, n)
    # one set of integrals for both grids: |theta_i| = pi (n - 1 - 2i) / (2 (n - 1)) lies on theta_o's
    I_f, I_b = chiang_hemisphere_integrals(np.concatenate([theta, theta_o]), sigma_a, eta=eta, beta_n=beta_n)
    G_f, G_b = I_f[n:], I_b[n:]
    I_f, I_b = I_f[:n].copy(), I_b[:n].copy()
    I_f[:, 0] *= specular
    I_b[:, 0] *= specular
    a_f, a_b, alpha_f, alpha_b, beta_f2, beta_b2 = _lobe_averages(I_f, I_b, lobe_shifts(shift),
                                                                  lobe_widths(roughness))
    A_b, delta_b, sigma_b2 = back_scattering(a_f, a_b, alpha_f, alpha_b, beta_f2, beta_b2, d_b)
    ng = (G_f + G_b) / (2.0 * PI)
    return DualTables(theta=theta, a_f=a_f, a_b=a_b, alpha_f=alpha_f, alpha_b=alpha_b, beta_f2=beta_f2,
                      beta_b2=beta_b2, A_b=A_b, delta_b=delta_b, sigma_b2=sigma_b2, theta_d=theta_o,
                      ng_r=ng[:, 0, 0], ng_tt=ng[:, 1], ng_trt=ng[:, 2], lobe_f=I_f, lobe_b=I_b,
                      ng_trrt=ng[:, 3])


def forward_tt(tables: DualTables) -> np.ndarray:
    """(size, 3): I_f^TT, the forward-scattered energy that TT carries, per channel, at most
    a_f (clamped as a_f is): the light whose direction one scattering keeps. TT leaves the fibre
    at theta_o = -theta_i within beta_n of straight through, while R, TRT and TRRT+ scattered
    into the forward half leave at any azimuth of it. Row 8 (Chiang's four lobes; zero for
    Marschner's, whose global term stays Zinke's)."""
    if tables.lobe_f.shape[1] != 4:
        return np.zeros_like(tables.a_f)
    return np.clip(tables.lobe_f[:, 1, :], 0.0, np.clip(tables.a_f, 0.0, 1.0))


def build_dual_lut(tables: DualTables) -> np.ndarray:
    """(9, size, 4) float32 texture data (row layout in the module docstring); a_f is
    clamped to [0, 1] (T_f = a_f^n then never grows with n)."""
    n = tables.theta.size
    lut = np.zeros((LUT_ROWS, n, 4), np.float64)
    lut[ROW_AB, :, :3] = tables.A_b
    lut[ROW_DELTA_B, :, :3] = tables.delta_b
    lut[ROW_SIGMA_B2, :, :3] = tables.sigma_b2
    lut[ROW_AF, :, :3] = np.clip(tables.a_f, 0.0, 1.0)
    lut[ROW_BETA_F2, :, :3] = tables.beta_f2
    lut[ROW_NG0, :, :3] = tables.ng_tt
    lut[ROW_NG0, :, 3] = tables.ng_r
    lut[ROW_NG1, :, :3] = tables.ng_trt
    if tables.ng_trrt is not None:
        lut[ROW_NG3, :, :3] = tables.ng_trrt
    lut[ROW_TT, :, :3] = forward_tt(tables)
    if not np.isfinite(lut).all():
        raise FloatingPointError("non-finite dual-scattering table")
    return lut.astype(np.float32)
