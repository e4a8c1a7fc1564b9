"""Chiang et al. 2016 hair fibre (HAIR_MODEL_CHIANG): the GLSL (analytic M_p, h-averaged
azimuthal table) against its NumPy twin (src/mane/twins/chiang.py, which integrates
over h itself), the twin's white furnace, the twin against Mitsuba 3's own ``hair`` BSDF, the
melanin presets and the settings.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mane.render.shading import PRESETS, ShadingSettings, evaluate_glsl, hair_preset
from mane.render.shading.chiang import (azimuthal_table, beta_m_from_roughness, logistic_scale, near_table,
                                        roughness_from_beta_m)
from mane.render.shading.melanin import fibre_color, melanin_to_sigma_a, sigma_a_to_color
from mane.twins import chiang as C
from mane.twins import shading as R

N = 1024


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def _material(s):
    m = R.material(s)
    m["beta_n"] = s.beta_n
    return m


CASES = {
    "brown": dict(melanin=PRESETS["brown"]),
    "blond": dict(melanin=PRESETS["blond"]),
    "rough_untilted": dict(melanin=(0.5, 0.5), roughness=math.radians(12), shift=0.0, beta_n=0.6),
    "smooth_white": dict(sigma_a=(0.0, 0.0, 0.0), roughness=math.radians(3), shift=math.radians(3), beta_n=0.15),
}


@pytest.mark.gpu
@pytest.mark.parametrize("case", list(CASES))
def test_chiang_glsl_matches_twin(gl, case):
    """GLSL (float32, 128 x 64 bilinear table) against the twin (float64, 512 h midpoints):
    max |error| <= 1 % of the peak, mean <= 0.5 % of the mean, p95 relative <= 1 %."""
    rng = np.random.default_rng(2016)
    T, V, L = _unit(rng, N), _unit(rng, N), _unit(rng, N)
    s = ShadingSettings(model="chiang", multiple_scattering="none", **CASES[case])
    g = evaluate_glsl(gl, s, T, V, L)
    r = C.chiang(T.astype(float), V.astype(float), L.astype(float), _material(s), n_h=512)
    assert np.isfinite(g).all() and (g >= 0).all()
    err = np.abs(g - r)
    print(case, "max/peak", err.max() / r.max(), "mean", err.mean() / r.mean())
    assert err.max() <= 0.01 * r.max()
    assert err.mean() <= 0.005 * r.mean()
    assert np.percentile(err / np.maximum(r, 0.01 * r.max()), 95) <= 0.01


@pytest.mark.gpu
def test_chiang_specular_scales_r_only(gl):
    rng = np.random.default_rng(3)
    T, V, L = _unit(rng, 256), _unit(rng, 256), _unit(rng, 256)
    s = ShadingSettings(model="chiang", multiple_scattering="none")
    full = evaluate_glsl(gl, s, T, V, L)
    no_r = evaluate_glsl(gl, dataclasses.replace(s, specular=0.0), T, V, L)
    lobes = C.fibre(*C._vec_angles(T.astype(float), V.astype(float), L.astype(float)), s.resolved_sigma_a(),
                    roughness=s.roughness, shift=s.shift, beta_n=s.beta_n, n_h=512, lobes=True)
    np.testing.assert_allclose(full - no_r, lobes[0], atol=0.02 * lobes[0].max())
    assert np.abs(full - no_r).mean() <= 1.01 * lobes[0].mean() and lobes[0].max() > 0


@pytest.mark.parametrize("theta_o_deg", [-70, -20, 0, 35, 80])
def test_twin_white_furnace(theta_o_deg):
    """Without absorption the fibre scatters all light: int f |cos| dw_i = 1 (pbrt's test), to
    the quadrature (256^2 directions, 64 h)."""
    a = C.directional_albedo(math.radians(theta_o_deg), np.zeros(3), roughness=math.radians(7.5),
                             shift=math.radians(-5), beta_n=0.3, n_h=64, n_theta=160, n_phi=128)
    assert abs(a[0] - 1.0) <= 6e-3, a
    absorbing = C.directional_albedo(math.radians(theta_o_deg), melanin_to_sigma_a(1.3, 0.2),
                                     roughness=math.radians(7.5), shift=math.radians(-5), beta_n=0.3, n_h=64,
                                     n_theta=96, n_phi=96)
    assert (absorbing < a - 0.3).all() and absorbing[0] > absorbing[1] > absorbing[2]


def test_table_white_furnace_and_symmetry():
    """The table's azimuthal integral is the h-averaged attenuation: sum_p int Nbar_p dphi = 1
    for sigma_a = 0 (2 x int over [0, pi], the table is even in phi)."""
    tab = azimuthal_table(np.zeros(3), n_phi=256, n_theta=8, n_h=256).astype(np.float64)
    n_phi = 256
    phi = np.linspace(0, math.pi, n_phi)
    for k in range(8):
        tt, r = tab[k, :n_phi, 0], tab[k, :n_phi, 3]
        trt = tab[k, n_phi:2 * n_phi, 0]
        n3 = tab[k, 2 * n_phi:, 0]
        total = 2 * np.trapezoid(r + tt + trt + n3, phi)
        assert abs(total - 1.0) <= 3e-3, (k, total)
        assert np.ptp(n3) == 0.0


def _mitsuba_hair(sigma, beta_m, beta_n, tilt):
    """Mitsuba 3's ``hair`` plugin and a function evaluating it with the eye at inclination
    theta_o, the light at theta_i and azimuth phi past the eye's, met at offset h: Mitsuba takes
    h from the azimuth of its wi (the eye; gamma = asin h past the frame's normal), the tangent is
    its frame's y, wo the light."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    bsdf = mi.load_dict({"type": "hair", "sigma_a": {"type": "rgb", "value": list(map(float, sigma))},
                         "longitudinal_roughness": beta_m, "azimuthal_roughness": beta_n, "scale_tilt": tilt,
                         "int_ior": 1.55, "ext_ior": 1.0})
    ctx = mi.BSDFContext()

    def at(theta_i, theta_o, phi, h):
        pv = math.pi / 2 + math.asin(h)
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f([0, 0, 1])
        si.wi = mi.Vector3f(math.cos(theta_o) * math.cos(pv), math.sin(theta_o), math.cos(theta_o) * math.sin(pv))
        pl = pv + phi
        wo = mi.Vector3f(math.cos(theta_i) * math.cos(pl), math.sin(theta_i), math.cos(theta_i) * math.sin(pl))
        return np.array(bsdf.eval(ctx, si, wo))

    return at


def test_twin_matches_mitsuba_hair_bsdf():
    """An independent golden value: Mitsuba 3's ``hair`` plugin (Chiang 2016 as in pbrt), its
    eval averaged over 64 offsets h at 24 random direction pairs, within 1 % (the twin's own h
    quadrature)."""
    beta_m, beta_n, tilt = 0.3, 0.3, 2.0
    sigma = melanin_to_sigma_a(1.3, 0.2)
    at = _mitsuba_hair(sigma, beta_m, beta_n, tilt)
    rng = np.random.default_rng(9)
    n, nh = 24, 64
    ti, to, ph = rng.uniform(-1.3, 1.3, n), rng.uniform(-1.3, 1.3, n), rng.uniform(0, math.pi, n)
    ref = C.fibre(ti, to, ph, sigma, roughness=roughness_from_beta_m(beta_m), shift=math.radians(tilt),
                  beta_n=beta_n, n_h=nh)
    for k in range(n):
        acc = sum(at(ti[k], to[k], ph[k], -1 + (j + 0.5) * 2 / nh) for j in range(nh)) / nh
        np.testing.assert_allclose(acc, ref[k], rtol=0.01, atol=1e-3 * ref.max())


def test_near_field_twin_matches_mitsuba_hair_bsdf_at_each_offset():
    """Chiang's near field, the fibre met at one offset h (pbrt's and Mitsuba's evaluation at a
    ray's hit), against Mitsuba's ``hair`` eval at that h with the light's azimuth phi past the
    eye's: the twin's fibre_near(theta_i, theta_o, phi, h) within 0.5 %; with h mirrored it is
    off by up to 100x (the sign convention the renderer's offset across the fibre follows)."""
    beta_m, beta_n, tilt = 0.3, 0.3, 2.0
    sigma = melanin_to_sigma_a(0.3, 0.1)
    at = _mitsuba_hair(sigma, beta_m, beta_n, tilt)
    rng = np.random.default_rng(5)
    n = 24
    ti, to = rng.uniform(-1.2, 1.2, n), rng.uniform(-1.2, 1.2, n)
    ph, h = rng.uniform(-math.pi, math.pi, n), rng.uniform(-0.97, 0.97, n)
    kw = dict(roughness=roughness_from_beta_m(beta_m), shift=math.radians(tilt), beta_n=beta_n)
    ref = np.array([at(ti[k], to[k], ph[k], h[k]) for k in range(n)])
    np.testing.assert_allclose(C.fibre_near(ti, to, ph, h, sigma, **kw), ref, rtol=0.005, atol=1e-4 * ref.max())
    mirrored = C.fibre_near(ti, to, ph, -h, sigma, **kw)
    assert np.abs(mirrored - ref).max() > 0.3 * ref.max()


def test_near_table_is_the_running_integral_of_the_far_fields_table():
    """chiang.near_table: layer 0 zero, non-decreasing in h (the integrand is >= 0), the last
    layer the far field's table on the same grid, and a middle layer the twin's integral from
    -1 to h (steps of gamma) within 0.5 % of the far field."""
    sigma = melanin_to_sigma_a(1.3, 0.2)
    c = near_table(sigma, n_phi=16, n_theta=8, bins=8, n_h=256)
    far = azimuthal_table(sigma, n_phi=16, n_theta=8, n_h=256)
    assert c.shape == (9, 8, 48, 4)
    assert not c[0].any()
    assert (np.diff(c, axis=0) >= -1e-7).all()
    np.testing.assert_allclose(c[-1], far, rtol=1e-5, atol=1e-7)
    # layer 2 of 8: gamma = -pi/2 + 2 pi / 8, h = sin(gamma); tile 1 (TRT) at phi_j, theta_k
    g_end = -math.pi / 2 + 2 * math.pi / 8
    j, k = 5, 3
    phi, theta = math.pi * j / 15, (math.pi / 2) * k / 7
    gs = -math.pi / 2 + (np.arange(4000) + 0.5) * (g_end + math.pi / 2) / 4000
    A, gamma_t = C.attenuation(np.full(gs.shape, math.cos(theta)), np.full(gs.shape, math.sin(theta)), np.sin(gs),
                               sigma, 1.55)
    n_trt = C.n_p(np.full(gs.shape, phi), 2, C.logistic_scale(0.3), gs, gamma_t)
    integral = 0.5 * ((A[2] * (n_trt * np.cos(gs))[:, None]).sum(axis=0) * (g_end + math.pi / 2) / 4000)
    np.testing.assert_allclose(c[2, k, 16 + j, :3], integral, rtol=0.005, atol=0.005 * far[k, 16 + j, :3].max())


@pytest.mark.gpu
@pytest.mark.parametrize("case", ["brown", "blond", "rough_untilted"])
def test_chiang_near_field_glsl_matches_twin(gl, case):
    """hair_bsdf's near field (harness.comp: hair_near_h, hair_near_dh) against the twin:
    the fibre at h (a footprint under HAIR_NEAR_MIN_DH) within 0.1 % of the peak; its mean over
    h +- footprint / 2 from the running integral's table against the twin's steps of gamma
    within 2 % on average (the table's 64 x 32 x 65 grid); a footprint of 2 or more is the
    far field, bit for bit."""
    rng = np.random.default_rng(11)
    T, V, L = _unit(rng, N), _unit(rng, N), _unit(rng, N)
    h = rng.uniform(-1.0, 1.0, N)
    s = ShadingSettings(model="chiang", multiple_scattering="none", near_field=True, **CASES[case])
    args = C.signed_angles(T, V, L)
    kw = dict(roughness=s.roughness, shift=s.shift, beta_n=s.beta_n)
    sigma = s.resolved_sigma_a()
    point = evaluate_glsl(gl, s, T, V, L, h=h, footprint=0.0)
    r = C.fibre_near(*args, h, sigma, **kw)
    assert np.abs(point - r).max() <= 1e-3 * r.max()
    for footprint in (0.2, 0.6, 1.2):
        g = evaluate_glsl(gl, s, T, V, L, h=h, footprint=footprint)
        mean = C.near_mean(*args, h - footprint / 2, h + footprint / 2, sigma, **kw)
        assert np.isfinite(g).all() and (g >= 0).all()
        assert np.abs(g - mean).mean() <= 0.02 * mean.mean(), footprint
    far = evaluate_glsl(gl, s, T, V, L)
    np.testing.assert_array_equal(evaluate_glsl(gl, s, T, V, L, h=h, footprint=2.0), far)


@pytest.mark.gpu
def test_near_field_finite_at_degenerate_directions_and_offsets(gl):
    """T along V or L, V along L, grazing: the near field (at one h and averaged over a
    footprint, at the fibre's middle and both edges) is finite and non-negative."""
    t, x, y = np.eye(3)[2], np.eye(3)[0], np.eye(3)[1]
    g = np.array([math.sin(1e-4), 0.0, math.cos(1e-4)])
    rows = [(t, t, x), (t, x, t), (t, t, t), (t, -t, t), (t, x, -x), (t, x, x), (t, g, x), (t, x, g), (t, g, -g),
            (t, x, y), (t, x, -y)]
    T, V, L = (np.array([r[k] for r in rows], np.float32) for k in range(3))
    s = ShadingSettings(model="chiang", multiple_scattering="none", near_field=True, melanin=(0.3, 0.1))
    for h in (-1.0, -0.999, 0.0, 0.999, 1.0):
        for footprint in (0.0, 0.05, 0.5, 1.9):
            f = evaluate_glsl(gl, s, T, V, L, h=h, footprint=footprint)
            assert np.isfinite(f).all() and (f >= 0).all(), (h, footprint, f)


def test_roughness_beta_m_mapping():
    assert abs(beta_m_from_roughness(roughness_from_beta_m(0.3)) - 0.3) <= 1e-9
    # sqrt(v_0) = 0.726 beta_m + 0.812 beta_m^2 + 3.7 beta_m^20 (Chiang eq. 7) = 2 roughness
    assert abs(2 * roughness_from_beta_m(0.3) - (0.726 * 0.3 + 0.812 * 0.09 + 3.7 * 0.3**20)) <= 1e-15
    assert abs(logistic_scale(0.3) - math.sqrt(math.pi / 8) * (0.265 * 0.3 + 1.194 * 0.09 + 5.372 * 0.3**22)) <= 1e-15
    s = ShadingSettings()
    assert 0.2 < s.beta_m < 0.35
    with pytest.raises(ValueError):
        beta_m_from_roughness(10.0)


# ------------------------------------------------------------------------------ colour and presets

def _srgb(c):
    c = np.clip(c, 0, 1)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def _hue_sat(rgb):
    import colorsys

    h, s, v = colorsys.rgb_to_hsv(*_srgb(np.asarray(rgb, float)))
    return h * 360, s, v


def test_presets_order_and_hues():
    """Presets from the literature: more eumelanin darker; red and auburn pheomelanin-rich;
    the brown preset's volume colour brown (orange-red hue 15-40 deg, value below 0.5 in
    sRGB: a dark orange is brown; ginger is a bright one), blond over 3x lighter, yellower."""
    vol = {k: sigma_a_to_color(melanin_to_sigma_a(*v)) for k, v in PRESETS.items()}
    lum = {k: float(R.luminance(c)) for k, c in vol.items()}
    assert lum["black"] < lum["dark_brown"] < lum["brown"] < lum["blond"] < lum["platinum"]
    ratio = {k: c[0] / c[1] for k, c in vol.items() if c[1] > 0}
    assert ratio["red"] > ratio["auburn"] > ratio["brown"]          # pheomelanin: redder
    h, s, v = _hue_sat(vol["brown"])
    assert 10 <= h <= 40 and v < 0.5, (h, s, v)
    h, s, v = _hue_sat(vol["blond"])
    assert 25 <= h <= 55 and v > 3 * _hue_sat(vol["brown"])[2], (h, s, v)
    for name in ("red", "auburn"):
        e, p = PRESETS[name]
        assert p > e
    assert PRESETS["grey"][1] == 0.0
    assert hair_preset("Dark Brown") == PRESETS["dark_brown"]
    assert ShadingSettings(melanin="auburn").melanin == PRESETS["auburn"]
    from mane.errors import UsageError

    with pytest.raises(UsageError):
        hair_preset("green")


def test_colour_models_take_one_fibres_colour():
    """Sadeghi, Scheuermann and Karis read melanin as one fibre's colour exp(-4 sigma_a)
    (Karis's C: C^(1/2) is the centre's TT transmittance exp(-2 sigma_a)), Kajiya-Kay as the
    fibre's diffuse albedo (test_kajiya_kay_reflects_what_chiangs_fibre_reflects), the fibre
    models keep the volume colour (ambient); an RGB colour is taken as given."""
    sig = melanin_to_sigma_a(*PRESETS["brown"])
    for model in ("kajiya_kay", "sadeghi", "scheuermann", "karis"):
        s = ShadingSettings(model=model)
        np.testing.assert_allclose(s.resolved_sigma_a(), sig)
        rgb = ShadingSettings(model=model, color=(0.3, 0.2, 0.1))
        np.testing.assert_allclose(rgb.resolved_color(), (0.3, 0.2, 0.1))
        if model in ("sadeghi", "karis"):
            np.testing.assert_allclose(s.resolved_color(), np.exp(-4 * sig))
            np.testing.assert_allclose(np.sqrt(fibre_color(sig)), np.exp(-2 * sig))
            np.testing.assert_allclose(fibre_color(rgb.resolved_sigma_a()), (0.3, 0.2, 0.1))
    # Kajiya-Kay and Scheuermann: the RGB opt-in is their diffuse colour, and melanin goes round through it
    for model in ("kajiya_kay", "scheuermann"):
        kk = ShadingSettings(model=model)
        back = ShadingSettings(model=model, color=tuple(kk.resolved_color()))
        np.testing.assert_allclose(back.resolved_sigma_a(), sig, rtol=1e-6)
    # Scheuermann's wrapped diffuse term sends toward the light's side what Kajiya-Kay's does
    from mane.twins import shading as S

    def toward_light(model):
        st = ShadingSettings(model=model)
        m = dict(S.material(st), specular=0.0)

        return _albedo_at(_in_fibre_frame(getattr(S, model), m), back=True)
    np.testing.assert_allclose(toward_light("scheuermann"), toward_light("kajiya_kay"), rtol=0.02)
    for model in ("chiang", "marschner"):
        np.testing.assert_allclose(ShadingSettings(model=model).resolved_color(), sigma_a_to_color(sig))


def _in_fibre_frame(model, m):
    """A twin's hair_bsdf (``model(T, V, L, m)``) as a function of the angles (theta_i, theta_o,
    phi): T along z, the eye at inclination theta_o, the light at theta_i and azimuth phi from it."""
    def bsdf(ti, to, ph):
        V = np.stack([np.cos(to), np.zeros_like(to), np.sin(to)], -1).reshape(-1, 3)
        L = np.stack([np.cos(ti) * np.cos(ph), np.cos(ti) * np.sin(ph), np.sin(ti)], -1).reshape(-1, 3)
        T = np.broadcast_to([0.0, 0.0, 1.0], V.shape)
        return model(T, V, L, m).reshape(np.shape(ti) + (3,))
    return bsdf


def _albedo_at(bsdf, theta_o=0.0, back=False, n_i=160, n_phi=160):
    """int bsdf(theta_i, theta_o, phi) dw_i over the sphere of lights (bsdf includes the
    projection factor; dw = cos theta_i dtheta_i dphi), or over its half toward the eye's side
    (|phi| < pi/2) with ``back``: midpoint rules."""
    ti = (np.arange(n_i) + 0.5) / n_i * math.pi - math.pi / 2
    span = math.pi if back else 2 * math.pi
    ph = (np.arange(n_phi) + 0.5) / n_phi * span - span / 2
    TI, PH = np.meshgrid(ti, ph, indexing="ij")
    f = bsdf(TI, np.full_like(TI, theta_o), PH)                        # (..., 3) or (..., k, 3)
    w = np.cos(TI) * (math.pi / n_i) * (span / n_phi)
    return np.einsum("ip...,ip->...", f, w)


@pytest.mark.parametrize("preset", ["brown", "blond"])
def test_kajiya_kay_reflects_what_chiangs_fibre_reflects(preset):
    """Kajiya-Kay's two terms carry what Chiang's fibre of the same melanin sends back, seen
    across the fibre (theta_o 0): its highlight (specular 1) the R lobe's albedo and width, its
    diffuse term toward the light's side (|phi| < pi/2) what TT + TRT + longer paths send there.
    Both sides integrated over the lights here from the twins (Chiang's far field from its
    equations, Kajiya-Kay's formula), not from the tables and closed forms of kajiya_kay.py."""
    from mane.twins import shading as S

    s = ShadingSettings(model="kajiya_kay", melanin=preset)
    m = S.material(s)

    def chiang(back):
        return _albedo_at(lambda ti, to, ph: np.moveaxis(C.fibre(
            ti, to, ph, m["sigma_a"], roughness=s.roughness, shift=s.shift, beta_n=s.beta_n, eta=s.eta, n_h=256,
            lobes=True), 0, -2), back=back)                              # (4, 3)

    def kk(ti, to, ph, part):
        mm = dict(m, specular=0.0) if part == "diffuse" else dict(m, color=np.zeros(3))
        return _in_fibre_frame(S.kajiya_kay, mm)(ti, to, ph)

    r_ref = chiang(False)[0]
    rest_back = chiang(True)[1:].sum(axis=0)
    np.testing.assert_allclose(_albedo_at(lambda *a: kk(*a, "highlight")), r_ref, rtol=0.03)
    np.testing.assert_allclose(_albedo_at(lambda *a: kk(*a, "diffuse"), back=True), rest_back, rtol=0.03)
    # the highlight is as wide as the R lobe: over theta_i at theta_o 0, phi 0, the same spread
    ti = np.linspace(-0.8, 0.8, 801)
    to, ph = np.zeros_like(ti), np.zeros_like(ti)
    r = C.fibre(ti, to, ph, np.zeros(3), roughness=s.roughness, shift=0.0, beta_n=s.beta_n, eta=s.eta, n_h=32,
                lobes=True)[0][:, 0]
    h = kk(ti, to, ph, "highlight")[:, 0]
    sd = [math.sqrt(float((y * ti**2).sum() / y.sum())) for y in (r, h)]
    assert abs(sd[1] / sd[0] - 1.0) < 0.1, sd


@pytest.mark.parametrize("model", ["sadeghi", "scheuermann"])
def test_artist_models_highlights_carry_chiangs_r_albedo(model):
    """Sadeghi's R lobe and Scheuermann's primary highlight (unit height as published) are
    scaled so that at specular 1 they reflect what Chiang's R lobe reflects across the fibre:
    both integrated over the sphere of lights from the twins (the colour set to 0 leaves only
    that term; Scheuermann's strand random at its mean, no tangent noise)."""
    from mane.twins import shading as S

    s = ShadingSettings(model=model)
    m = dict(S.material(s), color=np.zeros(3), strand_rand=np.float64(0.5))
    r_ref = _albedo_at(lambda ti, to, ph: C.fibre(ti, to, ph, np.zeros(3), roughness=s.roughness, shift=s.shift,
                                                  beta_n=s.beta_n, eta=s.eta, n_h=256, lobes=True)[0])

    np.testing.assert_allclose(_albedo_at(_in_fibre_frame(getattr(S, model), m), n_i=320, n_phi=320), r_ref,
                               rtol=0.03)


def test_defaults():
    s = ShadingSettings()
    assert s.model == "chiang" and s.melanin == PRESETS["brown"] and s.color is None
    assert s.resolved_multiple_scattering == "dual"
    assert ShadingSettings(model="karis").resolved_multiple_scattering == "dual"
    assert ShadingSettings(model="karis", multiple_scattering="karis").ms_mode == 1
    assert ShadingSettings(model="marschner_lut").resolved_multiple_scattering == "dual"
    for bad in (dict(beta_n=0.0), dict(beta_n=1.5), dict(chiang_size=4), dict(color=(1, 2))):
        with pytest.raises(ValueError):
            ShadingSettings(**bad)
    # NaN, infinities, text for a number, absurd table sizes and negative pigment: one line each,
    # before any table is built or allocated
    for bad, words in ((dict(roughness=float("nan")), "roughness must be a finite"),
                       (dict(specular=float("inf")), "specular must be a finite"),
                       (dict(roughness="0.1"), "roughness must be a finite"),
                       (dict(eta=1e9), "eta must be in"),
                       (dict(chiang_size=10**9), "chiang_size must be a whole number"),
                       (dict(dual_size=64.5), "dual_size must be a whole number"),
                       (dict(melanin=(float("nan"), 0.0)), "melanin must be a finite"),
                       (dict(melanin=(-1.0, 0.0)), "melanin values must be in"),
                       (dict(sigma_a=(float("inf"), 0.0, 0.0)), "sigma_a must be a finite"),
                       (dict(color=(0.1, -0.2, 0.3)), "color values must be in")):
        with pytest.raises(ValueError, match=words) as exc:
            ShadingSettings(**bad)
        assert "\n" not in str(exc.value)
