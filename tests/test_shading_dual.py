"""Zinke et al. 2008 dual scattering (HAIR_MULTIPLE_SCATTERING 2): the precomputed tables
(dual_scattering.py) and hair_ms_dual (dual_scattering.glsl) against its NumPy twin
(src/mane/twins/shading.py ms_dual).

Tolerance GLSL vs NumPy: |glsl - ref| <= 1e-3 * max(|ref|, floor), floor = 1e-3 * max(ref)
over the batch (float32 GPU against float64 NumPy on the same float32 inputs and table).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mane.render.shading import MULTIPLE_SCATTERING, ShadingSettings, evaluate_glsl
from mane.render.shading.luts import marschner_lobes
from mane.render.shading.dual_scattering import back_scattering, precompute_dual
from mane.twins import shading as R

N = 2048
MATERIALS = {
    "blond": dict(melanin=(0.3, 0.15)),
    "brown": dict(melanin=(1.3, 0.2)),
    "rgb": dict(color=(0.7, 0.55, 0.35), roughness=math.radians(5), shift=math.radians(-7), glint=1.5),
    "white": dict(sigma_a=(0.0, 0.0, 0.0)),
}


def _settings(name, model="marschner", **kw):
    return ShadingSettings(model=model, multiple_scattering="dual", **{**MATERIALS[name], **kw})


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


@pytest.fixture(scope="module")
def dirs():
    rng = np.random.default_rng(2008)
    T, V, L = _unit(rng, N), _unit(rng, N), _unit(rng, N)
    n = rng.uniform(0.0, 40.0, N)
    n[:64] = 0.0                      # lit surface: t = 1
    n[64:96] = np.inf                 # fully shadowed: t = 0
    return T, V, L, n


def _twin(s, T, V, L, t):
    return R.ms_dual(T.astype(float), V.astype(float), L.astype(float), R.material(s), t.astype(float),
                     s.dual_lut(), d_f=s.dual_density_front, d_b=s.dual_density_back,
                     max_hairs=s.dual_max_hairs, model="chiang" if s.model == "chiang" else "marschner")


def _close(g, r, rel=1e-3, floor=1e-3):
    scale = np.maximum(np.abs(r), floor * np.abs(r).max())
    return (np.abs(g - r) / scale).max()


# ------------------------------------------------------------------------------ GLSL vs NumPy

@pytest.mark.gpu
@pytest.mark.parametrize("material,model", [(m, "marschner") for m in MATERIALS]
                         + [("brown", "chiang"), ("white", "chiang")])
@pytest.mark.slow
def test_dual_glsl_matches_numpy(gl, dirs, material, model):
    T, V, L, n = dirs
    s = _settings(material, model)
    t = np.exp(-n).astype(np.float32)
    g = evaluate_glsl(gl, s, T, V, L, transmittance=t, multiple=True)
    r = _twin(s, T, V, L, t)
    assert np.isfinite(g).all() and (g >= 0).all()
    assert r.max() > 0
    assert _close(g, r) <= 1e-3, _close(g, r)


@pytest.mark.gpu
def test_dual_glsl_matches_numpy_other_constants(gl, dirs):
    T, V, L, n = dirs
    s = _settings("blond", dual_density_front=0.6, dual_density_back=0.8,
                  dual_max_hairs=20.0, specular=0.5, dual_size=32)
    t = np.exp(-n).astype(np.float32)
    g = evaluate_glsl(gl, s, T, V, L, transmittance=t, multiple=True)
    assert _close(g, _twin(s, T, V, L, t)) <= 1e-3


# ------------------------------------------------------------------------------ tables

def _albedo(theta_i, n_o=300, n_phi=160, **kw):
    """int S cos(theta_o) dw_o over the sphere (midpoint rule), sigma_a = 0."""
    to = (np.arange(n_o) + 0.5) / n_o * math.pi - math.pi / 2
    ph = (np.arange(n_phi) + 0.5) / n_phi * math.pi
    TO, PH = np.meshgrid(to, ph, indexing="ij")
    r, tt, trt = marschner_lobes(np.full_like(TO, theta_i), TO, PH, np.zeros(3), **kw)
    w = np.cos(TO) ** 2 * (math.pi / n_o) * (2 * math.pi / n_phi)
    return float(((r + tt[..., 0] + trt[..., 0]) * w).sum())


@pytest.mark.parametrize("beta_deg", [5.0, 7.5, 10.0])
@pytest.mark.slow
def test_forward_plus_backward_attenuation_at_most_one_without_absorption(beta_deg):
    tb = precompute_dual((0.0, 0.0, 0.0), beta_r=math.radians(beta_deg))
    total = tb.a_f + tb.a_b
    print(f"beta {beta_deg}: a_f + a_b in [{total.min():.3f}, {total.max():.3f}]")
    assert (tb.a_f >= 0).all() and (tb.a_b >= 0).all()
    assert (total <= 1.0).all(), total.max()
    # a_f + a_b is the directional albedo of hair_bsdf: the same integral on another grid
    for k in (0, 10, 25, 31, 40, 52, 63):
        assert abs(total[k, 0] - _albedo(tb.theta[k], beta_r=math.radians(beta_deg))) <= 3e-3
    np.testing.assert_allclose(tb.a_f[:, 0], tb.a_f[:, 2])   # no absorption: grey


@pytest.mark.parametrize("material", list(MATERIALS))
def test_back_scattering_table_ranges(material):
    s = _settings(material)
    tb = s.dual_tables()
    assert tb.theta.shape == (s.dual_size,)
    for arr in (tb.a_f, tb.a_b, tb.A_b, tb.delta_b, tb.sigma_b2, tb.beta_f2, tb.ng_tt, tb.ng_trt):
        assert arr.shape == (s.dual_size, 3) and np.isfinite(arr).all()
    assert (tb.A_b >= 0).all() and (tb.A_b <= 1).all()
    assert (tb.sigma_b2 >= 0).all() and (np.abs(tb.delta_b) <= math.pi / 2).all()
    assert (tb.a_f + tb.a_b <= 1.0 + 1e-9).all()
    # the lobe averages stay between the lobes' own parameters
    alpha = s.shift * np.array([1.0, -0.5, -1.5])
    beta2 = (s.roughness * np.array([1.0, 0.5, 2.0])) ** 2
    for a in (tb.alpha_f, tb.alpha_b):
        assert (a >= alpha.min() - 1e-12).all() and (a <= alpha.max() + 1e-12).all()
    for b in (tb.beta_f2, tb.beta_b2):
        assert (b >= beta2.min() - 1e-12).all() and (b <= beta2.max() + 1e-12).all()
    # more absorption, less multiple scattering
    if material == "brown":
        assert tb.A_b.max() < _settings("blond").dual_tables().A_b.max()


def test_back_scattering_formulas_limits():
    af = np.linspace(0, 1, 101)[:, None] * np.ones(3)
    for ab in (0.0, 0.05, 0.2):
        A_b, delta_b, sigma_b2 = back_scattering(af, np.full_like(af, ab) * (af <= 1 - ab), 0.01, -0.05,
                                                 0.003, 0.01)
        assert np.isfinite(A_b).all() and np.isfinite(delta_b).all() and np.isfinite(sigma_b2).all()
        assert (A_b >= 0).all() and (A_b <= 1).all()
        if ab == 0.0:
            assert (A_b == 0).all() and (sigma_b2 == 0).all()
    # a_f + a_b <= 1 bounds A_b by max a^2/(1+a) + a^2/(1+a)^3 = 0.625 (at a_f -> 1)
    af = np.linspace(0, 0.999, 500)[:, None] * np.ones(3)
    A_b, _, _ = back_scattering(af, 1 - af, 0.0, 0.0, 0.003, 0.01)
    assert A_b.max() <= 0.625


@pytest.mark.slow
def test_lut_layout_and_integration_converged():
    s = _settings("blond", dual_size=16)
    lut = s.dual_lut()
    assert lut.shape == (9, 16, 4) and lut.dtype == np.float32
    assert (lut[:5, :, 3] == 0).all() and (lut[6:, :, 3] == 0).all()
    assert (lut[7] == 0).all() and (lut[8] == 0).all()   # Marschner: no TRRT+ lobe, no diffuse split
    assert (lut[3, :, :3] <= 1).all()
    tb = s.dual_tables()
    fine = precompute_dual(s.resolved_sigma_a(), beta_r=s.roughness, alpha_r=s.shift, size=8,
                           n_theta_o=512, n_phi=256, n_phi_g=1024)
    coarse = precompute_dual(s.resolved_sigma_a(), beta_r=s.roughness, alpha_r=s.shift, size=8)
    assert np.abs(fine.a_f - coarse.a_f).max() <= 2e-3
    assert np.abs(fine.a_b - coarse.a_b).max() <= 2e-3
    assert np.abs(fine.A_b - coarse.A_b).max() <= 5e-3 * fine.A_b.max()
    assert tb.theta[0] == -math.pi / 2 and tb.theta[-1] == math.pi / 2


# ------------------------------------------------------------------------------ model behaviour

def test_forward_transmittance_never_grows_with_hairs():
    """T_f = exp(-n (1 - a_f)) (Poisson count of fibres met, mean n = -ln t): 1 with no fibre,
    never below the direct light t = exp(-n), never growing with n."""
    for model in ("marschner", "chiang"):
        for material in MATERIALS:
            lut = _settings(material, model).dual_lut()
            a_f = lut[3, :, :3].astype(np.float64)
            n = np.linspace(0, 64, 257)
            T_f = np.exp(-n[:, None, None] * (1 - np.clip(a_f, 0, 1))[None])
            assert (np.diff(T_f, axis=0) <= 0).all()
            assert (T_f[0] == 1).all()
            assert (T_f >= np.exp(-n)[:, None, None] - 1e-15).all()


def test_poisson_forward_transmittance_from_the_count_distribution():
    """exp(-n (1 - a)) is E[a^k] for k ~ Poisson(n): summed term by term."""
    from scipy.stats import poisson

    for n in (0.3, 1.0, 4.0, 12.0):
        for a in (0.0, 0.2, 0.7, 1.0):
            k = np.arange(200)
            assert abs((poisson.pmf(k, n) * a**k).sum() - math.exp(-n * (1 - a))) <= 1e-12


def test_direct_and_diffuse_split_from_the_count_distribution():
    """Each fibre met TT-scatters the light with probability c a_f / a_f: the light that kept
    the beam's direction is E[(c a_f)^k] = exp(-n (1 - c a_f)) (k ~ Poisson(n)), the diffuse
    rest E[a_f^k] - E[(c a_f)^k]: summed term by term."""
    from scipy.stats import poisson

    k = np.arange(200)
    for n in (0.3, 1.0, 4.0, 12.0):
        for a, c in ((0.58, 0.93), (0.17, 0.77), (1.0, 0.5), (0.6, 0.0)):
            kept = (poisson.pmf(k, n) * (c * a) ** k).sum()
            total = (poisson.pmf(k, n) * a**k).sum()
            assert abs(kept - math.exp(-n * (1 - c * a))) <= 1e-12
            assert abs((total - kept) - (math.exp(-n * (1 - a)) - math.exp(-n * (1 - c * a)))) <= 1e-12


def test_forward_tt_row():
    """Row 8: the forward-scattered energy TT carries, per channel, at most a_f (Chiang's
    tables; 0 for Marschner's), from made-up lobe energies and from the blond fibre's own."""
    from mane.render.shading.dual_scattering import ROW_TT, DualTables, build_dual_lut, forward_tt

    n = 8
    lobe_f = np.zeros((n, 4, 3))
    lobe_f[:, :, 0] = [0.1, 0.6, 0.2, 0.1]           # red: TT 0.6 of a_f 1.0
    lobe_f[:, :, 1] = [0.1, 0.2, 0.0, 0.1]           # green: 0.2 of 0.4
    lobe_f[:, :, 2] = [0.0, 0.0, 0.0, 0.0]
    z = np.zeros((n, 3))
    tb = DualTables(theta=np.linspace(-1, 1, n), a_f=lobe_f.sum(axis=1), a_b=z, alpha_f=z, alpha_b=z,
                    beta_f2=z, beta_b2=z, A_b=z, delta_b=z, sigma_b2=z, theta_d=np.linspace(0, 1, n),
                    ng_r=np.zeros(n), ng_tt=z, ng_trt=z, lobe_f=lobe_f, lobe_b=lobe_f, ng_trrt=z)
    assert ROW_TT == 8
    assert np.allclose(forward_tt(tb), [0.6, 0.2, 0.0], rtol=1e-12)
    assert np.allclose(build_dual_lut(tb)[8, :, :3], [0.6, 0.2, 0.0], rtol=1e-6)
    assert (build_dual_lut(tb)[:, :, 3][[0, 1, 2, 3, 4, 6, 7, 8]] == 0).all()   # alpha: N^G_R only
    lobe_f[:, 1, 0] = 1.3                             # past a_f (clamped to 1): clamped to it
    assert np.allclose(forward_tt(DualTables(**{**tb.__dict__, "lobe_f": lobe_f}))[:, 0], 1.0)
    blond = _settings("blond", "chiang", dual_size=16).dual_lut()
    share = blond[8, :, :3] / np.maximum(blond[3, :, :3], 1e-9)
    assert ((share >= 0) & (share <= 1 + 1e-6)).all() and (share[8] > 0.8).all()   # TT carries most of blond's a_f
    assert (_settings("blond", dual_size=16).dual_lut()[8] == 0).all()


def test_diffuse_part_is_isotropic_with_the_fibre_albedo():
    """With no TT (row 8 zero) every scattered photon is diffuse: the global term is then d_f T_f (T_f - t)
    times the fibre's albedo at theta_o (a_f + a_b of the tables, the white-furnace split) over
    4 pi (isotropic radiance of the same fluence), whatever the light's direction."""
    s = _settings("blond", "chiang", dual_size=64)
    lut = s.dual_lut()
    lut[8] = 0.0
    tb = s.dual_tables()
    rng = np.random.default_rng(12)
    T, V, L = _unit(rng, 256), _unit(rng, 256), _unit(rng, 256)
    t = rng.uniform(0.01, 0.9, 256)
    kw = dict(d_b=s.dual_density_back, max_hairs=s.dual_max_hairs, model="chiang")
    m = R.material(s)
    part = R.ms_dual(T, V, L, m, t, lut, d_f=1.0, **kw) - R.ms_dual(T, V, L, m, t, lut, d_f=0.0, **kw)
    a = R.angles(T, V, L)
    xi = np.clip((a["theta_i"] + math.pi / 2) / math.pi, 0, 1) * 63
    a_f = np.stack([np.interp(xi, np.arange(64), lut[3, :, ch].astype(float)) for ch in range(3)], axis=1)
    T_f = np.exp(np.log(t)[:, None] * (1 - a_f))
    albedo = np.stack([np.interp(np.abs(a["theta_o"]), tb.theta, (tb.a_f + tb.a_b)[:, ch]) for ch in range(3)], axis=1)
    want = T_f * (T_f - t[:, None]) * albedo / (4 * math.pi)
    assert np.abs(part - want).max() <= 0.02 * want.max(), np.abs(part - want).max() / want.max()


def test_chiang_tables_are_the_white_furnace_split():
    """Chiang's a_f + a_b is pbrt's white-furnace integral: 1 without absorption at every
    theta (to the h and phi quadrature), split ~ evenly only for the R lobe."""
    s = _settings("white", "chiang", dual_size=16)
    tb = s.dual_tables()
    total = tb.a_f + tb.a_b
    assert np.abs(total - 1.0).max() <= 5e-3, total
    brown = _settings("brown", "chiang", dual_size=16).dual_tables()
    blond = _settings("blond", "chiang", dual_size=16).dual_tables()
    assert (brown.a_f < blond.a_f).all() and (blond.a_f[:, 0] > blond.a_f[:, 2]).all()
    assert tb.lobe_f.shape == (16, 4, 3)


def test_direct_back_scattering_normalisation():
    """Mane's normalisation of f_direct_back (t = 1, d_b = 1): azimuthally uniform 1 / (2 pi) and
    1/2 G(theta_h - Delta_b, sigma_b^2) unit-integral over theta_o, so int f_direct_back /
    cos(theta_i) cos^2(theta_d) dtheta_o dphi is A_b times the Gaussian's mass inside theta_o in
    [-pi/2, pi/2] (the 1/cos^2 theta_d of the lobe against the measure cos^2 theta_o is Marschner's
    approximation and not part of the normalisation)."""
    s = _settings("blond", dual_density_back=1.0)
    lut = s.dual_lut()
    n_o, n_phi = 600, 48
    to = (np.arange(n_o) + 0.5) / n_o * math.pi - math.pi / 2
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * math.pi
    TO, PH = (a.ravel() for a in np.meshgrid(to, ph, indexing="ij"))
    V = np.stack([np.cos(TO) * np.cos(PH), np.cos(TO) * np.sin(PH), np.sin(TO)], -1)
    T = np.broadcast_to([0.0, 0.0, 1.0], V.shape)
    x = np.arange(lut.shape[1], dtype=float)
    for ti in (-0.6, -0.2, 0.0, 0.3, 0.7):
        L = np.broadcast_to([math.cos(ti), 0.0, math.sin(ti)], V.shape)
        f = R.ms_dual(T, V, L, R.material(s), np.ones(len(V)), lut, d_b=1.0) / math.cos(ti)
        td = 0.5 * (TO - ti)
        mass = (f * (np.cos(td) ** 2 * (math.pi / n_o) * (2 * math.pi / n_phi))[:, None]).sum(0)
        xi = (ti + math.pi / 2) / math.pi * (lut.shape[1] - 1)
        A_b, delta_b, sigma_b2 = (np.array([np.interp(xi, x, lut[row, :, c]) for c in range(3)]) for row in (0, 1, 2))
        c, w = 2 * delta_b - ti, 2 * np.sqrt(sigma_b2)          # the lobe in theta_o
        inside = np.array([0.5 * (math.erf((math.pi / 2 - c[k]) / (w[k] * math.sqrt(2)))
                                  - math.erf((-math.pi / 2 - c[k]) / (w[k] * math.sqrt(2)))) for k in range(3)])
        np.testing.assert_allclose(mass, A_b * inside, rtol=5e-3)


@pytest.mark.gpu
@pytest.mark.slow
def test_no_hairs_towards_the_light_only_local_back_scattering(gl, dirs):
    """n = 0 (t = 1): the global term vanishes, leaving d_b f_direct_back cos theta_i."""
    T, V, L, _ = dirs
    s = _settings("blond")
    base = evaluate_glsl(gl, s, T, V, L, transmittance=1.0, multiple=True)
    no_front = evaluate_glsl(gl, dataclasses.replace(s, dual_density_front=0.0), T, V, L,
                             transmittance=1.0, multiple=True)
    no_back = evaluate_glsl(gl, dataclasses.replace(s, dual_density_back=0.0), T, V, L,
                            transmittance=1.0, multiple=True)
    assert base.max() > 0
    # d_f is a compile-time constant (HAIR_DUAL_DF): with d_f = 0 the driver's compiler may
    # fold the global term away and schedule the local term differently (NVIDIA: 1 ulp
    # differences), so equal up to float32 rounding rather than bit for bit.
    np.testing.assert_allclose(base, no_front, rtol=1e-6, atol=0)
    assert np.abs(no_back).max() == 0.0
    # the twin's local term alone (F_scatter = 0) matches
    r = _twin(s, T, V, L, np.ones(N, np.float32))
    assert _close(base, r) <= 1e-3
    # and in the shadow the global term appears
    shadowed = evaluate_glsl(gl, s, T, V, L, transmittance=0.35, multiple=True)
    shadowed_no_front = evaluate_glsl(gl, dataclasses.replace(s, dual_density_front=0.0), T, V, L,
                                      transmittance=0.35, multiple=True)
    assert (shadowed - shadowed_no_front).max() > 0


@pytest.mark.gpu
def test_global_term_fades_with_many_hairs(gl, dirs):
    """A deep point (t -> 0, n -> max_hairs) keeps only T_f = a_f^n of the light: the result
    shrinks towards 0 and never goes negative; the lit surface is brighter."""
    T, V, L, _ = dirs
    s = _settings("white")
    lit = evaluate_glsl(gl, s, T, V, L, transmittance=1.0, multiple=True)
    deep = evaluate_glsl(gl, s, T, V, L, transmittance=0.0, multiple=True)
    mid = evaluate_glsl(gl, s, T, V, L, transmittance=0.35**3, multiple=True)
    assert (deep >= 0).all() and deep.mean() < 0.1 * mid.mean()
    print("mean dual term: lit", lit.mean(0), "n=3", mid.mean(0), "n=max", deep.mean(0))


def _degenerate():
    t = np.array([0.0, 0.0, 1.0])
    x = np.array([1.0, 0.0, 0.0])
    g = np.array([math.sin(1e-4), 0.0, math.cos(1e-4)])   # 1e-4 rad from T
    rows = [(t, t, x), (t, x, t), (t, t, t), (t, -t, t), (t, t, -t), (t, x, -x), (t, x, x),
            (t, g, x), (t, x, g), (t, g, -g), (t, g, g), (t, -g, g), (t, x, np.array([0, 1.0, 0])),
            (t, -t, -t), (t, -g, -g), (-t, x, t)]
    T, V, L = (np.array([r[k] for r in rows], np.float32) for k in range(3))
    return T, V, L


@pytest.mark.gpu
@pytest.mark.parametrize("material", ["white", "brown"])
def test_dual_degenerate_directions_finite_and_non_negative(gl, material):
    T, V, L = _degenerate()
    s = _settings(material)
    for t in (0.0, 1e-30, 1e-6, 0.3, 0.9999, 1.0):
        f = evaluate_glsl(gl, s, T, V, L, transmittance=t, multiple=True)
        assert np.isfinite(f).all() and (f >= 0).all(), (t, f)
        r = _twin(s, T, V, L, np.full(len(T), t, np.float32))
        assert np.isfinite(r).all() and (r >= 0).all()


# ------------------------------------------------------------------------------ interface

def test_dual_settings():
    s = _settings("blond")
    assert s.ms_mode == MULTIPLE_SCATTERING["dual"] == 2
    d = s.defines()
    assert d["HAIR_MULTIPLE_SCATTERING"] == 2
    assert float(d["HAIR_DUAL_DF"]) == 1.0 and float(d["HAIR_DUAL_DB"]) == 1.0   # both measured against the path tracer (docs/quality.md)
    assert s.dual_tables() is s.dual_tables()       # cached per material
    for bad in (dict(dual_density_front=1.5),
                dict(dual_max_hairs=0.0), dict(dual_size=4)):
        with pytest.raises(ValueError):
            _settings("blond", **bad)


@pytest.mark.parametrize("material", ["brown", "blond", "white"])
def test_chiang_global_azimuthal_functions_conserve_each_lobes_energy(material):
    """The forward-scattered light reaches a fibre from spread-out azimuths, so the global term
    uses an azimuthally constant N^G_p. Whatever the spread, a fibre cannot scatter more than
    its lobe's attenuation: over the circle 2 pi N^G_p(theta_o) must equal Abar_p(theta_o), the
    mean over h of Chiang's A_p (the trimmed logistic integrates to 1), from the NumPy twin's
    attenuation. (Zinke's 2/pi int_{pi/2}^{pi} N_p dphi, the forward half's average, is the
    right value only with the eye straight behind the light: used at every azimuth it gives
    2x the energy of TT and none of R's, and made Sintel blond 25 % too bright.)"""
    from mane.twins import chiang as C

    s = _settings(material, "chiang")
    sigma_a = s.resolved_sigma_a()
    lut = s.dual_lut()
    size = lut.shape[1]
    hs = -1.0 + (np.arange(2048) + 0.5) / 1024.0
    for theta_o in (0.0, 0.4, 0.9):
        A, _ = C.attenuation(np.full_like(hs, math.cos(theta_o)), np.full_like(hs, math.sin(theta_o)), hs,
                             sigma_a, s.eta)
        Abar = [a.mean(axis=0) for a in A]                     # (3,) per lobe
        x = np.arange(size) / (size - 1) * (math.pi / 2)
        ng = lambda row, c: np.interp(theta_o, x, lut[row, :, c])  # noqa: E731
        got_r = 2 * math.pi * ng(5, 3)
        got = [np.array([2 * math.pi * ng(row, c) for c in range(3)]) for row in (5, 6, 7)]
        assert got_r == pytest.approx(Abar[0][0], rel=0.02, abs=2e-4)
        for p, g in zip((1, 2, 3), got):
            np.testing.assert_allclose(g, Abar[p], rtol=0.02, atol=2e-4)
