"""NumPy twins of src/mane/render/shading/*.glsl, written from the published equations.

Every function takes T, V, L as (N, 3) unit vectors and a ShadingSettings-like material
(see ``material()``) and returns (N, 3) float64 = hair_bsdf (radiance out per radiance in,
projection factor included). Marschner also has a scalar-angle entry point used by the LUT
builder and the albedo integration.
"""
from __future__ import annotations

import math

import numpy as np

INV_PI = 1.0 / math.pi
SQRT_2PI_INV = 0.39894228040143267794


def material(settings, strand_rand=0.0):
    """The HairMaterial values (as float64 NumPy) of ShadingSettings ``settings``."""
    u = settings.material_uniforms()
    return {
        "color": np.asarray(u["u_material.color"], np.float64),
        "specular": u["u_material.specular"],
        "sigma_a": np.asarray(u["u_material.sigma_a"], np.float64),
        "roughness": u["u_material.roughness"],
        "shift": u["u_material.shift"],
        "eta": u["u_material.eta"],
        "glint": u["u_material.glint"],
        "strand_rand": np.asarray(strand_rand, np.float64),
        "caustic_width": settings.caustic_width,
        "caustic_fade": settings.caustic_fade,
        "caustic_limit": settings.caustic_limit,
        "tt_width": settings.tt_width,
        "glint_width": settings.glint_width,
        "noise": settings.noise,
        "norm": settings.model_norm,   # Kajiya-Kay's, Sadeghi's, Scheuermann's scale (None for the others)
    }


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _norm(v):
    return np.sqrt(_dot(v, v))


def safe_normalize(v, fallback=None):
    l2 = _dot(v, v)
    ok = l2 > 1e-20
    out = v / np.sqrt(np.where(ok, l2, 1.0))[..., None]
    fb = np.zeros_like(v) if fallback is None else np.broadcast_to(fallback, v.shape)
    return np.where(ok[..., None], out, fb)


def gaussian(beta, x):
    return np.exp(-0.5 * x * x / (beta * beta)) * (SQRT_2PI_INV / beta)


def luminance(c):
    return c @ np.array([0.2126, 0.7152, 0.0722])


def angles(T, V, L):
    """hair_common.glsl hair_angles: dict of sin_i, cos_i, sin_o, cos_o, theta_i, theta_o, phi."""
    si = np.clip(_dot(T, L), -1, 1)
    so = np.clip(_dot(T, V), -1, 1)
    lp = L - si[:, None] * T
    vp = V - so[:, None] * T
    ci = np.minimum(_norm(lp), 1.0)
    co = np.minimum(_norm(vp), 1.0)
    x = _dot(vp, lp)
    y = _norm(np.cross(vp, lp))
    phi = np.where(np.abs(x) + y > 1e-12, np.arctan2(y, x), math.pi / 2)
    return {"sin_i": si, "cos_i": ci, "sin_o": so, "cos_o": co,
            "theta_i": np.arctan2(si, np.maximum(ci, 1e-30)),
            "theta_o": np.arctan2(so, np.maximum(co, 1e-30)), "phi": phi, "lp": lp, "vp": vp}


# ------------------------------------------------------------------------------ Kajiya-Kay

def kajiya_kay(T, V, L, m):
    tl = np.clip(_dot(T, L), -1, 1)
    tv = np.clip(_dot(T, V), -1, 1)
    sl = np.sqrt(np.maximum(0, 1 - tl * tl))
    sv = np.sqrt(np.maximum(0, 1 - tv * tv))
    c = np.clip(sl * sv - tl * tv, 0, 1)
    p = np.clip(1.0 / max(4.0 * m["roughness"] ** 2, 1e-6), 1.0, 4096.0)
    spec = m["specular"] * m["norm"] * c**p
    return sl[:, None] * (m["color"][None, :] * INV_PI**2 + spec[:, None])


# ------------------------------------------------------------------------------ multiple scattering

def ms_karis(T, V, L, m, transmittance):
    tv = _dot(T, V)
    N = safe_normalize(V - tv[:, None] * T)
    kk = 1 - np.abs(np.clip(_dot(T, L), -1, 1))
    wrap = np.clip((_dot(N, L) + 1) * 0.25, 0, 1)
    diffuse = INV_PI * (wrap + (kk - wrap) * 0.33)
    c = np.maximum(m["color"], 1e-4)
    tint = (c / max(luminance(c), 1e-4))[None, :] ** (1 - np.clip(np.asarray(transmittance), 0, 1))[..., None]
    return np.sqrt(c)[None, :] * diffuse[:, None] * tint


# ------------------------------------------------------------------------------ Marschner

def marschner(T, V, L, m, energy_clamp=True):
    from ..render.shading.luts import marschner_bsdf_angles

    a = angles(T, V, L)
    return marschner_bsdf_angles(
        a["theta_i"], a["theta_o"], a["phi"], m["sigma_a"], specular=m["specular"], eta=m["eta"],
        beta_r=m["roughness"], alpha_r=m["shift"], glint=m["glint"], caustic_width=m["caustic_width"],
        caustic_fade=m["caustic_fade"], caustic_limit=m["caustic_limit"], energy_clamp=energy_clamp)


def _cos_phi(a):
    lp, vp = a["lp"], a["vp"]
    den = _dot(lp, lp) * _dot(vp, vp)
    return np.where(den > 1e-24, np.clip(_dot(lp, vp) / np.sqrt(np.where(den > 0, den, 1)), -1, 1), 0.0)


# ------------------------------------------------------------------------------ Sadeghi 2010

SADEGHI_I = np.array([0.45, 1.0, 0.3])


def sadeghi(T, V, L, m):
    a = angles(T, V, L)
    th = 0.5 * (a["theta_i"] + a["theta_o"])
    cos_d = np.maximum(np.cos(0.5 * (a["theta_o"] - a["theta_i"])), 1e-2)
    alpha = m["shift"] * np.array([1, -0.5, -1.5])
    beta = m["roughness"] * np.array([1, 0.5, 2])
    M = SADEGHI_I * np.exp(-0.5 * ((th[:, None] - alpha) / beta) ** 2)
    phi = a["phi"]
    nr = np.cos(0.5 * phi)
    ntt = np.exp(-0.5 * ((math.pi - phi) / m["tt_width"]) ** 2)
    g_angle = np.radians(30 + 15 * np.broadcast_to(m["strand_rand"], phi.shape))
    ntrt = nr + m["glint"] * np.exp(-0.5 * ((g_angle - phi) / m["glint_width"]) ** 2)
    f = (m["specular"] * M[:, 0] * nr)[:, None] + m["color"] * (M[:, 1] * ntt + M[:, 2] * ntrt)[:, None]
    return np.maximum(f * (m["norm"] * a["cos_i"] / cos_d**2)[:, None], 0)


# ------------------------------------------------------------------------------ Scheuermann 2004

def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0, 1)
    return t * t * (3 - 2 * t)


def _strand_spec(t, H, e):
    th = np.clip(_dot(t, H), -1, 1)
    return _smoothstep(-1, 0, th) * np.sqrt(np.maximum(0, 1 - th * th)) ** e


def scheuermann(T, V, L, m):
    N = safe_normalize(V - _dot(T, V)[:, None] * T)
    rand = np.broadcast_to(m["strand_rand"], T.shape[:1])
    noise = (rand - 0.5) * m["noise"]
    t1 = safe_normalize(T + (m["shift"] + noise)[:, None] * N, T)
    t2 = safe_normalize(T + (-1.5 * m["shift"] + noise)[:, None] * N, T)
    H = safe_normalize(L + V, T)
    r = max(m["roughness"], 1e-3)
    e1 = min(1 / r**2, 4096.0)
    e2 = min(0.25 / r**2, 4096.0)
    sparkle = np.maximum(0, 1 + m["glint"] * (np.mod(61.0 * rand, 1.0) - 0.5))
    diffuse = m["color"] * INV_PI * (0.25 + 0.75 * np.clip(_dot(N, L), 0, 1))[:, None]
    k = m["specular"] * m["norm"]
    return (diffuse + (k * _strand_spec(t1, H, e1))[:, None]
            + (k * sparkle * _strand_spec(t2, H, e2))[:, None] * m["color"])


# ------------------------------------------------------------------------------ Karis 2016

def _schlick(f0, x):
    t = 1 - np.clip(x, 0, 1)
    return f0 + (1 - f0) * t**5


def karis(T, V, L, m):
    a = angles(T, V, L)
    si, so = a["sin_i"], a["sin_o"]
    cphi = _cos_phi(a)
    cos_d = np.maximum(np.cos(0.5 * (a["theta_o"] - a["theta_i"])), 1e-2)
    lp, vp = a["lp"], a["vp"]
    ok = _dot(lp, lp) * _dot(vp, vp) > 1e-24
    chp = np.where(ok, np.minimum(0.5 * _norm(safe_normalize(lp) + safe_normalize(vp)), 1.0), math.sqrt(0.5))
    f0 = ((m["eta"] - 1) / (m["eta"] + 1)) ** 2
    # Karis's Gaussian runs over sin(theta_i) + sin(theta_o) ~ 2 theta_h: mane's theta_h width
    # and shift (Marschner's beta_R, alpha_R) enter doubled
    alpha = 2 * m["shift"] * np.array([1, -0.5, -2])
    beta = 2 * max(m["roughness"], 1e-3) * np.array([1, 0.5, 2])
    M = gaussian(beta, (si + so)[:, None] - alpha)
    C = np.maximum(m["color"], 1e-4)
    nr = 0.25 * chp * _schlick(f0, np.sqrt(np.clip(0.5 + 0.5 * _dot(V, L), 0, 1)))
    aa = 1 / (1.19 / cos_d + 0.36 * cos_d)
    h = chp * (1 + aa * (0.6 - 0.8 * cphi))
    f = _schlick(f0, cos_d * np.sqrt(np.clip(1 - h * h, 0, 1)))
    ntt = ((1 - f) ** 2)[:, None] * C ** (0.5 * np.sqrt(np.maximum(0, 1 - (h * aa) ** 2)) / cos_d)[:, None] \
        * np.exp(-3.65 * cphi - 3.98)[:, None]
    f2 = _schlick(f0, cos_d * 0.5)
    ntrt = ((1 - f2) ** 2 * f2)[:, None] * C ** (0.8 / cos_d)[:, None] * np.exp(17 * cphi - 16.78)[:, None]
    return np.maximum((m["specular"] * M[:, 0] * nr)[:, None] + M[:, 1, None] * ntt + M[:, 2, None] * ntrt, 0)


# ------------------------------------------------------------------------------ Zinke 2008 dual scattering

def dual_sample(lut, row, x):
    """GL_LINEAR sampling of row ``row`` of the (9, size, 4) dual table at texel coordinate
    x in [0, size - 1] (grid point j at x = j; texel centres), float64 weights."""
    n = lut.shape[1]
    x = np.clip(x, 0.0, n - 1)
    i0 = np.minimum(np.floor(x).astype(int), n - 2)
    f = (x - i0)[:, None]
    tab = lut[row].astype(np.float64)
    return tab[i0] * (1 - f) + tab[i0 + 1] * f


def _g_var(v, x):
    v = np.maximum(v, 1e-8)
    return np.exp(-0.5 * x * x / v) / np.sqrt(2 * math.pi * v)


def ms_dual(T, V, L, m, transmittance, lut, *, d_f=0.7, d_b=0.7, max_hairs=64.0, model="marschner"):
    """dual_scattering.glsl hair_ms_dual (Zinke 2008 Algorithm 1, mane's normalisation), from
    the table data ``lut`` (ShadingSettings.dual_lut()). Returns (N, 3).

    The forward transmittance: n = -ln t fibres met on average (Poisson, so that none is met
    with probability t), T_f = E[a_f^k] = exp(-n (1 - a_f)). ``model="chiang"``: four lobes,
    TRT shifted by -2 alpha, TRRT+ unshifted with TRT's width, N^G read at |theta_o|."""
    a = angles(T, V, L)
    th = 0.5 * (a["theta_i"] + a["theta_o"])
    td = 0.5 * (a["theta_o"] - a["theta_i"])
    inv_cd2 = 1.0 / np.maximum(np.cos(td), 1e-2) ** 2
    size = lut.shape[1]
    xi = np.clip((a["theta_i"] + math.pi / 2) / math.pi, 0, 1) * (size - 1)
    chiang = model == "chiang"
    xd = np.clip(np.abs(a["theta_o"] if chiang else td) / (math.pi / 2), 0, 1) * (size - 1)
    A_b = dual_sample(lut, 0, xi)[:, :3]
    delta_b = dual_sample(lut, 1, xi)[:, :3]
    sigma_b2 = dual_sample(lut, 2, xi)[:, :3]
    a_f = dual_sample(lut, 3, xi)[:, :3]
    beta_f2 = dual_sample(lut, 4, xi)[:, :3]
    ng0 = dual_sample(lut, 5, xd)
    ng_trt = dual_sample(lut, 6, xd)[:, :3]
    ng_trrt = dual_sample(lut, 7, xd)[:, :3]
    t = np.clip(np.broadcast_to(np.asarray(transmittance, np.float64), th.shape), 0, 1)
    n = np.where(t < 1, np.minimum(-np.log(np.maximum(t, 1e-30)), max_hairs), 0.0)
    back_norm = (inv_cd2 / (4 * math.pi))[:, None]
    f_direct_back = back_norm * A_b * _g_var(sigma_b2, th[:, None] - delta_b)
    T_f = np.exp(-n[:, None] * (1.0 - np.clip(a_f, 0.0, 1.0)))
    sigma_f2 = n[:, None] * beta_f2
    alpha = m["shift"] * np.array([1.0, -0.5, -2.0 if chiang else -1.5, 0.0])
    beta2 = (m["roughness"] * np.array([1.0, 0.5, 2.0, 2.0])) ** 2
    mg = [0.5 * _g_var(beta2[p] + sigma_f2, (th - alpha[p])[:, None]) for p in range(4)]
    f_scatter_s = (m["specular"] * ng0[:, 3:4] * mg[0] + ng0[:, :3] * mg[1] + ng_trt * mg[2]
                   + ng_trrt * mg[3]) * inv_cd2[:, None]
    f_scatter_back = back_norm * A_b * _g_var(sigma_b2 + sigma_f2, th[:, None] - delta_b)
    inside = (t < 1)[:, None]
    if chiang:
        # Poisson count k of fibres met, the light passing each by TT with probability I_f^TT
        # (row 8): what is still in the beam's direction is E[I_tt^k] - t = exp(-n (1 - I_tt)) - t;
        # the rest of T_f is diffuse, attenuated once more (twice the path) and isotropic
        T_dir = np.exp(-n[:, None] * (1.0 - dual_sample(lut, 8, xi)[:, :3]))
        scattered = np.maximum(T_dir - t[:, None], 0.0) * inside
        diffuse = np.maximum(T_f - T_dir, 0.0) * T_f * inside
        albedo_o = 2 * math.pi * (m["specular"] * ng0[:, 3:4] + ng0[:, :3] + ng_trt + ng_trrt)
        f_diffuse = d_f * diffuse * albedo_o / (4 * math.pi)
    else:
        scattered = np.maximum(T_f - t[:, None], 0.0) * inside
        f_diffuse = 0.0
    f = t[:, None] * d_b * f_direct_back + scattered * d_f * (f_scatter_s + d_b * f_scatter_back)
    return np.maximum(f * a["cos_i"][:, None] + f_diffuse, 0.0)
