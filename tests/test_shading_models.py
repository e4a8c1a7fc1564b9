"""Hair shading models: GLSL (harness.comp) against the NumPy twins, LUT against analytic,
energy, symmetry, melanin, degenerate directions.

Tolerance GLSL vs NumPy: |glsl - ref| <= 1e-3 * max(|ref|, floor), floor = 1e-3 * max(ref)
over the batch (float32 GPU against float64 NumPy on the same float32 inputs).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mane.render.shading import MODELS, ShadingSettings, evaluate_glsl, melanin_to_sigma_a
from mane.render.shading.luts import marschner_lobes
from mane.render.shading.melanin import (EUMELANIN_SIGMA_A, PHEOMELANIN_SIGMA_A, color_to_sigma_a,
                                         sigma_a_to_color)
from mane.twins import shading as R

pytestmark = pytest.mark.gpu

N = 2048
ANALYTIC = ["kajiya_kay", "marschner", "sadeghi", "scheuermann", "karis"]


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


@pytest.fixture(scope="module")
def dirs():
    rng = np.random.default_rng(7)
    return _unit(rng, N), _unit(rng, N), _unit(rng, N), rng.random(N).astype(np.float32)


def _close(g, r, rel=1e-3, floor=1e-3):
    scale = np.maximum(np.abs(r), floor * np.abs(r).max())
    err = np.abs(g - r) / scale
    return err.max()


@pytest.mark.parametrize("colour", ["rgb", "melanin"])
@pytest.mark.parametrize("model", ANALYTIC)
def test_glsl_matches_numpy(gl, dirs, model, colour):
    T, V, L, rand = dirs
    kw = {"melanin": (1.3, 0.3)} if colour == "melanin" else {"color": (0.55, 0.4, 0.25)}
    s = ShadingSettings(model=model, **kw)
    g = evaluate_glsl(gl, s, T, V, L, strand_rand=rand)
    r = getattr(R, model)(T.astype(float), V.astype(float), L.astype(float), R.material(s, rand.astype(float)))
    assert np.isfinite(g).all() and (g >= 0).all()
    assert _close(g, r) <= 1e-3


def test_marschner_glsl_matches_numpy_without_energy_clamp(gl, dirs):
    T, V, L, rand = dirs
    s = ShadingSettings(model="marschner", sigma_a=(0.2, 0.4, 0.9), energy_clamp=False, glint=2.0,
                        roughness=math.radians(5))
    g = evaluate_glsl(gl, s, T, V, L)
    r = R.marschner(T.astype(float), V.astype(float), L.astype(float), R.material(s), energy_clamp=False)
    assert _close(g, r) <= 1e-3


def test_karis_multiple_scattering_matches_numpy(gl, dirs):
    T, V, L, rand = dirs
    s = ShadingSettings(model="karis", color=(0.4, 0.25, 0.1), multiple_scattering="karis")
    trans = np.linspace(0, 1, N).astype(np.float32)
    g = evaluate_glsl(gl, s, T, V, L, transmittance=trans, multiple=True)
    r = R.ms_karis(T.astype(float), V.astype(float), L.astype(float), R.material(s), trans.astype(float))
    assert _close(g, r) <= 1e-3


def test_marschner_lut_matches_analytic(gl, dirs):
    """LUT (256^2 RGBA16F, bilinear) vs analytic GLSL: mean |error| <= 1 % of the mean,
    max <= 5 % of the peak, 95th percentile relative error (floor 1 % of peak) <= 1 %."""
    T, V, L, _ = dirs
    s = ShadingSettings(model="marschner", melanin=(0.8, 0.2))
    a = evaluate_glsl(gl, s, T, V, L)
    b = evaluate_glsl(gl, dataclasses.replace(s, model="marschner_lut"), T, V, L)
    err = np.abs(a - b)
    assert err.mean() <= 0.01 * a.mean()
    assert err.max() <= 0.05 * a.max()
    assert np.percentile(err / np.maximum(a, 0.01 * a.max()), 95) <= 0.01


def _grazing_dirs(rng, n):
    """T, V, L with |theta_i| and |theta_o| in [60, 89.5] deg (opposite or equal signs), phi uniform."""
    T = _unit(rng, n).astype(float)
    a = np.cross(T, rng.normal(size=(n, 3)))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(T, a)

    def along(theta, phi):
        return np.sin(theta)[:, None] * T + np.cos(theta)[:, None] * (np.cos(phi)[:, None] * a + np.sin(phi)[:, None] * b)

    sign = rng.choice([-1.0, 1.0], size=(2, n))
    ti = sign[0] * np.radians(rng.uniform(60, 89.5, n))
    to = sign[1] * np.radians(rng.uniform(60, 89.5, n))
    L = along(ti, np.zeros(n))
    V = along(to, rng.uniform(0, 2 * math.pi, n))
    return T.astype(np.float32), V.astype(np.float32), L.astype(np.float32)


def test_marschner_lut_matches_analytic_bench_inputs_grazing(gl):
    """The quality bench's material (melanin (1.3, 0.3)) on 4096 random directions plus 4096
    near-grazing ones (|theta_i|, |theta_o| in [60, 89.5] deg): max |error| <= 2 % of the peak
    (1.2 % measured, the TT/TRT Fresnel kink near theta_d = 80 deg; 0.12 % on the random half;
    before: 58 %, from sin theta / cos phi tables, the baked clamp and the baked N_R)."""
    rng = np.random.default_rng(11)
    T, V, L = _unit(rng, 4096), _unit(rng, 4096), _unit(rng, 4096)
    GT, GV, GL = _grazing_dirs(rng, 4096)
    T, V, L = np.concatenate([T, GT]), np.concatenate([V, GV]), np.concatenate([L, GL])
    s = ShadingSettings(model="marschner", melanin=(1.3, 0.3))
    a = evaluate_glsl(gl, s, T, V, L)
    b = evaluate_glsl(gl, dataclasses.replace(s, model="marschner_lut"), T, V, L)
    assert np.isfinite(b).all() and (b >= 0).all()
    err = np.abs(a - b)
    assert err.max() <= 0.02 * a.max(), err.max() / a.max()
    assert err.mean() <= 0.005 * a.mean()
    assert np.percentile(err / np.maximum(a, 0.01 * a.max()), 95) <= 0.005
    g = slice(4096, None)   # the grazing half alone, against its own peak
    assert err[g].max() <= 0.02 * a[g].max(), err[g].max() / a[g].max()


def test_lut_layout():
    s = ShadingSettings(model="marschner_lut", lut_size=32)
    m, n = s.luts()
    assert m.shape == (32, 32, 4) and n.shape == (32, 64, 4)
    assert m.dtype == np.float32 and np.isfinite(m).all() and np.isfinite(n).all()
    assert (m[..., 3] > 0).all() and (m[..., 3] <= 1).all()
    assert n[:, 32:, 3].max() == 0


def _albedo(theta_i, n_o=200, n_phi=128, **kw):
    """Directional albedo int S cos(theta_o) dw_o over the sphere, midpoint rule in (theta_o, phi)."""
    to = (np.arange(n_o) + 0.5) / n_o * math.pi - math.pi / 2
    ph = (np.arange(n_phi) + 0.5) / n_phi * math.pi
    TO, PH = np.meshgrid(to, ph, indexing="ij")
    r, tt, trt = marschner_lobes(np.full_like(TO, theta_i), TO, PH, np.zeros(3), **kw)
    s = r + tt[..., 0] + trt[..., 0]
    w = np.cos(TO) ** 2 * (math.pi / n_o) * (2 * math.pi / n_phi)   # phi over [-pi, pi] by symmetry
    return float((s * w).sum())


ALBEDO_ANGLES = (-89, -85, -75, -60, -45, -30, 0, 30, 45, 60, 75, 85, 89)


def test_marschner_albedo_never_above_one():
    s = ShadingSettings(model="marschner", sigma_a=(0, 0, 0))
    kw = dict(eta=s.eta, beta_r=s.roughness, alpha_r=s.shift, glint=s.glint, caustic_width=s.caustic_width,
              caustic_fade=s.caustic_fade, caustic_limit=s.caustic_limit)
    values = {d: _albedo(math.radians(d), **kw) for d in ALBEDO_ANGLES}
    print("Marschner sigma_a=0 albedo:", {d: round(v, 3) for d, v in values.items()})
    assert all(0 < v <= 1.0 for v in values.values()), values
    for beta in (5, 10):
        vals = [_albedo(math.radians(d), **{**kw, "beta_r": math.radians(beta)}) for d in ALBEDO_ANGLES]
        assert max(vals) <= 1.0, (beta, vals)


def test_kajiya_kay_symmetric(gl, dirs):
    T, V, L, _ = dirs
    s = ShadingSettings(model="kajiya_kay", roughness=0.3)
    a = evaluate_glsl(gl, s, T, V, L)
    b = evaluate_glsl(gl, s, T, L, V)
    c = evaluate_glsl(gl, s, -T, V, L)
    sin_l = np.sqrt(np.maximum(0, 1 - np.sum(T * L, 1) ** 2))[:, None]
    sin_v = np.sqrt(np.maximum(0, 1 - np.sum(T * V, 1) ** 2))[:, None]
    ok = (sin_l > 1e-2)[:, 0] & (sin_v > 1e-2)[:, 0]
    np.testing.assert_allclose((a / sin_l)[ok], (b / sin_v)[ok], rtol=1e-4, atol=1e-6)   # reciprocal BRDF
    np.testing.assert_allclose(a, c, rtol=1e-5, atol=1e-7)


def test_melanin_sigma_a():
    np.testing.assert_allclose(melanin_to_sigma_a(1, 0), EUMELANIN_SIGMA_A)
    np.testing.assert_allclose(melanin_to_sigma_a(0, 1), PHEOMELANIN_SIGMA_A)
    np.testing.assert_allclose(EUMELANIN_SIGMA_A, (0.419, 0.697, 1.37))     # Chiang et al. 2016
    np.testing.assert_allclose(PHEOMELANIN_SIGMA_A, (0.187, 0.4, 1.05))
    c = np.linspace(0, 8, 33)
    for pigment in (0, 1):
        s = np.array([melanin_to_sigma_a(x, 0) if pigment == 0 else melanin_to_sigma_a(0, x) for x in c])
        assert (np.diff(s, axis=0) > 0).all()
        assert (s[1:, 0] < s[1:, 1]).all() and (s[1:, 1] < s[1:, 2]).all()   # absorbs blue most
    # darker with more melanin, red > green > blue (brown hair)
    col = np.array([sigma_a_to_color(melanin_to_sigma_a(x, 0.2)) for x in c])
    assert (np.diff(col, axis=0) < 0).all()
    assert (col[1:, 0] > col[1:, 1]).all() and (col[1:, 1] > col[1:, 2]).all()
    np.testing.assert_allclose(sigma_a_to_color(color_to_sigma_a((0.5, 0.3, 0.1))), (0.5, 0.3, 0.1), rtol=1e-9)
    with pytest.raises(ValueError):
        melanin_to_sigma_a(-1, 0)


def _degenerate():
    t = np.array([0.0, 0.0, 1.0])
    x = np.array([1.0, 0.0, 0.0])
    g = np.array([math.sin(1e-4), 0.0, math.cos(1e-4)])   # 1e-4 rad from T
    rows = [(t, t, x), (t, x, t), (t, t, t), (t, -t, t), (t, t, -t), (t, x, -x), (t, x, x),
            (t, g, x), (t, x, g), (t, g, -g), (t, g, g), (t, -g, g), (t, x, np.array([0, 1.0, 0]))]
    T, V, L = (np.array([r[k] for r in rows], np.float32) for k in range(3))
    return T, V, L


@pytest.mark.parametrize("model", list(MODELS))
@pytest.mark.slow
def test_degenerate_directions_finite_and_non_negative(gl, model):
    T, V, L = _degenerate()
    s = ShadingSettings(model=model, melanin=(1.0, 0.2))
    for rand in (0.0, 0.999):
        for multiple in (False, True):
            f = evaluate_glsl(gl, s, T, V, L, strand_rand=rand, transmittance=0.3, multiple=multiple)
            assert np.isfinite(f).all() and (f >= 0).all(), (model, multiple, f)


def test_settings_interface(gl):
    s = ShadingSettings(model="karis", melanin=(1.3, 0.2))
    d = s.defines()
    assert d["HAIR_MODEL"] == MODELS["karis"] == 5
    u = s.material_uniforms()
    assert set(u) == {f"u_material.{k}" for k in
                      ("color", "specular", "sigma_a", "roughness", "shift", "eta", "glint", "strand_rand")}
    np.testing.assert_allclose(u["u_material.sigma_a"], melanin_to_sigma_a(1.3, 0.2))
    with pytest.raises(ValueError):
        ShadingSettings(model="phong")
    for name in ("energy_clamp", "near_field"):   # a switch is a bool, not any truthy value
        for bad in ("maybe", 2, None):
            with pytest.raises(ValueError, match=f"{name} must be true or false"):
                ShadingSettings(**{name: bad})
    hash(s)   # frozen


VERT = """#version 430
in vec2 in_pos;
void main() { gl_Position = vec4(in_pos, 0.0, 1.0); }
"""
FRAG = """#version 430
#include "hair_shading.glsl"
uniform HairMaterial u_material;
out vec4 frag;
void main() {
    HairMaterial m = u_material;
    m.strand_rand = fract(gl_FragCoord.x * 0.37);
    vec3 T = vec3(0.0, 1.0, 0.0), V = vec3(0.0, 0.0, 1.0), L = normalize(vec3(0.3, 0.4, 1.0));
    frag = vec4(hair_bsdf(T, V, L, m) + hair_multiple_scattering(T, V, L, m, 0.5), 1.0);
}
"""


@pytest.mark.parametrize("model,multiple", [(m, "auto") for m in MODELS]
                         + [(m, "karis") for m in ("chiang", "marschner_lut", "kajiya_kay")])
def test_fragment_stage_compiles_and_binds(gl, tmp_path, model, multiple):
    from mane.gpu.glsl import program
    from mane.render.shading import LUT_UNIT_DUAL, SHADER_DIR

    (tmp_path / "v.vert").write_text(VERT)
    (tmp_path / "f.frag").write_text(FRAG)
    s = ShadingSettings(model=model, multiple_scattering=multiple, lut_size=32, dual_size=16)
    prog = program(gl, vertex=tmp_path / "v.vert", fragment=tmp_path / "f.frag", defines=s.defines(),
                   include_dirs=[SHADER_DIR])
    s.bind(prog, gl)
    # a driver drops the fields a model does not read (dual scattering: no colour on NVIDIA)
    assert any(f"u_material.{f}" in prog for f in ("color", "sigma_a", "roughness", "specular"))
    if s.resolved_multiple_scattering == "dual":
        assert "hair_dual_lut" in prog and prog["hair_dual_lut"].value == LUT_UNIT_DUAL
    if model == "chiang":
        from mane.render.shading import LUT_UNIT_CHIANG

        assert "hair_chiang_n" in prog and prog["hair_chiang_n"].value == LUT_UNIT_CHIANG


def test_karis_r_lobe_as_wide_and_shifted_as_marschners():
    """Karis's Gaussian runs over sin(theta_i) + sin(theta_o) ~ 2 theta_h: with the same
    roughness (beta_R, a width in theta_h) and shift its R lobe peaks where Marschner's does,
    theta_o = 2 alpha_R - theta_i (5 %), with the same width in theta_o, 2 beta_R (10 %: the
    Gaussian is over sines and times N_R's Fresnel)."""
    s = ShadingSettings(model="karis", color=(1e-4, 1e-4, 1e-4), roughness=math.radians(6), shift=math.radians(-5))
    m = R.material(s)
    to = np.radians(np.linspace(-60, 60, 4801))
    T = np.tile([0.0, 0.0, 1.0], (to.size, 1))
    L = np.tile([1.0, 0.0, 0.0], (to.size, 1))                    # theta_i = 0
    V = np.stack([np.cos(to), np.zeros_like(to), np.sin(to)], -1)  # phi = 0: the R lobe's azimuth
    f = R.karis(T, V, L, m)[:, 0]
    w = f / f.sum()
    mean = (w * to).sum()
    std = math.sqrt((w * (to - mean) ** 2).sum())
    peak = to[np.argmax(f)]
    assert abs(peak - 2 * s.shift) <= 0.05 * abs(2 * s.shift), (math.degrees(peak), math.degrees(2 * s.shift))
    assert abs(std - 2 * s.roughness) <= 0.1 * 2 * s.roughness, (math.degrees(std), math.degrees(2 * s.roughness))
    assert abs(mean - 2 * s.shift) <= 0.1 * abs(2 * s.shift)


@pytest.mark.parametrize("preset", ["brown", "blond"])
def test_marschner_trt_carries_chiangs_trt_energy(preset):
    """Marschner's caustic treatment (Hunz Algorithm 1) removes the TRT caustic and puts a glint
    of weight k_G back. At the default k_G the TRT lobe integrated over azimuth and theta_o is
    within 0.7-1.1 of Chiang's far-field TRT (the NumPy twin of Chiang 2016, the path tracer's
    model) on the same fibre; at the old 0.5 it was 0.39-0.62 (issue 12's "TRT 0.16-0.59x")."""
    import warnings

    from mane.render.shading.chiang import beta_m_from_roughness
    from mane.render.shading.luts import marschner_lobes
    from mane.twins import chiang as C

    s = ShadingSettings(melanin=preset)
    m = R.material(s)
    phis = np.linspace(0.0, math.pi, 181)
    tos = np.radians(np.linspace(-85.0, 85.0, 35))
    TO, PH = np.meshgrid(tos, phis, indexing="ij")

    def energy(trt, ti):   # (theta_o, phi, 3) -> (3,): over phi in [-pi, pi] and theta_o
        per_o = 2.0 * np.trapezoid(trt, phis, axis=1)
        return np.trapezoid(per_o * np.cos(tos)[:, None], tos, axis=0)

    ratios = {}
    for glint in (s.glint, 0.5):
        out = []
        for ti in np.radians([-40.0, -20.0, 0.0, 20.0]):
            TI = np.full_like(TO, ti)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                _, _, trt = marschner_lobes(TI, TO, PH, m["sigma_a"], eta=m["eta"], beta_r=m["roughness"],
                                            alpha_r=m["shift"], glint=glint, energy_clamp=False)
            chiang = C.fibre(TI, TO, PH, m["sigma_a"], roughness=beta_m_from_roughness(m["roughness"]),
                             shift=m["shift"], beta_n=s.beta_n, eta=m["eta"], n_h=32, lobes=True)[2]
            out.append(energy(trt * math.cos(ti), ti)[0] / energy(chiang, ti)[0])
        ratios[glint] = np.array(out)
    assert s.glint == 1.0
    assert np.all((ratios[1.0] > 0.7) & (ratios[1.0] < 1.1)), ratios
    assert np.all(ratios[0.5] < 0.65), ratios
