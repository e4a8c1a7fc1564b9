"""mane.reference: the path-traced ground truth (Mitsuba 3, the ``reference`` extra).

The reference is checked against physics and geometry, never against mane's shading: the
B-spline through the renderer's points, the camera's projection, the radiance of one fibre
against Chiang's far-field R lobe integrated in NumPy, the cuticle tilt's direction, energy
ordering with melanin, determinism and the cache. The geometry is compared with the compute
rasteriser's coverage.
"""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from mane import reference as ref
from mane.errors import ManeError, UsageError
from mane.reference.scene import ExpandedStrands, HairMaterial, bspline_control_points, bspline_eval
from mane.render import RenderSettings
from mane.render.camera import Camera
from mane.render.lights import Light


@pytest.fixture(scope="module")
def mi():
    return pytest.importorskip("mitsuba")


# ---------------------------------------------------------------- no Mitsuba needed
def test_bspline_control_points_of_a_line_are_the_evenly_spaced_points():
    P = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]], float)
    C, _ = bspline_control_points(P)
    # hand solution: the B-spline of evenly spaced collinear control points is the line
    np.testing.assert_allclose(C[0, :, 0], [-1, 0, 1, 2, 3, 4], atol=1e-12)


def test_bspline_passes_through_every_point_and_follows_a_circle():
    n = 24
    a = np.linspace(0, 1.5 * math.pi, n)
    P = np.stack([np.cos(a), np.sin(a), 0.1 * a], axis=1)[None] * 0.01       # a 1 cm helix arc
    C, R = bspline_control_points(P, np.linspace(3e-4, 1e-4, n)[None])
    at_knots = bspline_eval(C, np.arange(n, dtype=float))
    np.testing.assert_allclose(at_knots, P, atol=1e-12)
    # half-way between knots the spline stays on the helix (radius 1 cm) to far below a width:
    # inside to 0.3 um, in the end segments (straightened by the clamped ends) to 20 um
    t = np.arange(n - 1) + 0.5
    off = np.abs(np.hypot(*bspline_eval(C, t)[0, :, :2].T) - 0.01)
    assert off[3:-3].max() < 3e-7 and off.max() < 2.5e-5
    radii = bspline_eval(R[..., None], np.arange(n, dtype=float))[0, :, 0]
    np.testing.assert_allclose(radii, np.linspace(3e-4, 1e-4, n), atol=1e-12)


def test_control_points_from_the_raw_polyline_would_cut_curls_by_more_than_a_width():
    # why the control points are solved for: a curl of radius 3 mm sampled every 60 degrees
    a = np.linspace(0, 4 * math.pi, 13)
    P = np.stack([0.003 * np.cos(a), 0.003 * np.sin(a), 0.002 * a], axis=1)[None]
    raw = bspline_eval(np.concatenate([2 * P[:, :1] - P[:, 1:2], P, 2 * P[:, -1:] - P[:, -2:-1]], axis=1),
                       np.arange(13, dtype=float))
    assert np.linalg.norm(raw - P, axis=2).max() > 3e-4       # half a root width off
    C, _ = bspline_control_points(P)
    assert np.linalg.norm(bspline_eval(C, np.arange(13, dtype=float)) - P, axis=2).max() < 1e-12


def test_longitudinal_width_maps_to_chiang_roughness():
    # sqrt(v) = 0.726 b + 0.812 b^2 + 3.7 b^20; at b = 0.3: 0.2178 + 0.07308 + 1.29e-10
    assert ref.beta_m_to_lobe_width(0.3) == pytest.approx(0.29088, abs=1e-5)
    assert ref.lobe_width_to_beta_m(0.29088) == pytest.approx(0.3, abs=1e-5)
    b = ref.lobe_width_to_beta_m(math.radians(7.5))
    assert 0.726 * b + 0.812 * b * b == pytest.approx(math.radians(7.5), rel=1e-9)
    with pytest.raises(UsageError):
        ref.lobe_width_to_beta_m(0.0)


def test_material_from_settings_takes_melanin_width_tilt_and_ior():
    s = RenderSettings(shading="marschner", hair_color=None,
                       shading_options={"melanin": (1.3, 0.2), "roughness": math.radians(7.5),
                                        "shift": math.radians(-5.0), "eta": 1.6})
    m = HairMaterial.from_settings(s)
    assert (m.eumelanin, m.pheomelanin, m.sigma_a) == (1.3, 0.2, None)
    assert m.tilt == pytest.approx(-5.0) and m.eta == 1.6
    # beta_R is a width in theta_h, the R lobe's standard deviation in theta_o is twice it
    assert m.longitudinal_roughness == pytest.approx(ref.lobe_width_to_beta_m(2 * math.radians(7.5)))
    assert m.azimuthal_roughness == 0.3
    np.testing.assert_allclose(m.resolved_sigma_a(), 1.3 * np.array([0.419, 0.697, 1.37]) + 0.2 * np.array([0.187, 0.4, 1.05]))
    # an RGB colour (no melanin): Chiang's inversion, as the real-time models use
    from mane.render.shading import color_to_sigma_a

    m2 = HairMaterial.from_settings(RenderSettings(shading="marschner", hair_color=(0.3, 0.2, 0.1)))
    np.testing.assert_allclose(m2.sigma_a, color_to_sigma_a((0.3, 0.2, 0.1)))


def test_missing_mitsuba_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "mitsuba", None)      # "import mitsuba" raises ImportError
    with pytest.raises(ManeError, match=r"pip install mane\[reference\]") as info:
        ref.mitsuba()
    assert "\n" not in str(info.value)
    assert not ref.available()


def test_variant_comes_from_the_argument_then_the_environment_then_scalar(monkeypatch):
    monkeypatch.delenv(ref.VARIANT_ENV, raising=False)
    assert ref.resolve_variant() == "scalar_rgb" == ref.MITSUBA_VARIANT
    monkeypatch.setenv(ref.VARIANT_ENV, "cuda_ad_rgb")
    assert ref.resolve_variant() == "cuda_ad_rgb"
    assert ref.resolve_variant("llvm_ad_rgb") == "llvm_ad_rgb"          # the argument wins
    # a pass is a process start and (JIT variants) a kernel compile: more samples per pass there
    assert ref.default_pass_spp("scalar_rgb") == ref.DEFAULT_PASS_SPP == 64
    assert ref.default_pass_spp("cuda_ad_rgb") == ref.default_pass_spp() == 512
    with pytest.raises(UsageError, match="scalar_rgb, cuda_ad_rgb, llvm_ad_rgb") as info:
        ref.resolve_variant("cuda_rgb")
    assert "\n" not in str(info.value)
    # "auto": the GPU's variant where it starts, else scalar_rgb, probed once a process
    import importlib

    render_module = importlib.import_module("mane.reference.render")

    render_module._auto_variant.cache_clear()
    monkeypatch.setattr(render_module, "available", lambda v=None: v == "cuda_ad_rgb")
    assert ref.resolve_variant("auto") == "cuda_ad_rgb"
    monkeypatch.setattr(render_module, "available", lambda v=None: False)
    assert ref.resolve_variant("auto") == "cuda_ad_rgb"                 # probed once a process
    render_module._auto_variant.cache_clear()
    monkeypatch.setenv(ref.VARIANT_ENV, "auto")
    assert ref.resolve_variant() == "scalar_rgb"
    render_module._auto_variant.cache_clear()
    monkeypatch.setenv(ref.VARIANT_ENV, "spectral")
    with pytest.raises(UsageError, match=r"\$MANE_REFERENCE_VARIANT"):
        ref.render(strands=_strand([[0, 0, 0], [0, 1, 0]], 1e-3), camera=Camera(), spp=1)


# ---------------------------------------------------------------- with Mitsuba
def _strand(points, width):
    P = np.asarray(points, np.float32)[None]
    return ExpandedStrands(P, np.full(P.shape[:2], width, np.float32))


def _line(a, b, n=8):
    t = np.linspace(0, 1, n)[:, None]
    return (1 - t) * np.asarray(a, float) + t * np.asarray(b, float)


def test_camera_projects_a_strand_where_mane_does(mi, tmp_path):
    # a short vertical strand at a known point off the axis; mane's view-projection says where
    cam = Camera(eye=(0.1, 0.05, 0.6), target=(0.0, 0.0, 0.0), fov_y=35.0)
    W, H = 80, 60
    p = np.array([0.04, 0.02, 0.03])
    st = _strand(_line(p - [0, 0.01, 0], p + [0, 0.01, 0]), 0.002)
    s = RenderSettings(size=(W, H))
    cov = ref.hair_coverage(strands=st, camera=cam, settings=s, spp=16, cache_dir=tmp_path)
    clip = cam.view_projection(W / H) @ np.append(p, 1.0)
    ndc = clip[:2] / clip[3]
    x, y = (ndc[0] + 1) / 2 * W, (1 - ndc[1]) / 2 * H           # pixel units, top row first
    ys, xs = np.indices(cov.shape) + 0.5
    cx, cy = (cov * xs).sum() / cov.sum(), (cov * ys).sum() / cov.sum()
    assert abs(cx - x) < 0.25 and abs(cy - y) < 0.25


def _chiang_r_backscatter(beta_m, beta_n, eta, h):
    """Chiang 2016 / pbrt-v3's R term for light and eye along the same direction perpendicular
    to the fibre (theta_i = theta_o = 0, delta phi = 0, no tilt), per unit irradiance."""
    from scipy.special import i0e

    v = (0.726 * beta_m + 0.812 * beta_m ** 2 + 3.7 * beta_m ** 20) ** 2
    mp = i0e(1 / v) / (v * (1 - math.exp(-2 / v)))            # I0(1/v) / (2 v sinh(1/v))
    ci = np.sqrt(1 - h * h)                                    # cos of the incidence angle
    st = np.sqrt(np.maximum(0, 1 - (1 - ci * ci) / eta ** 2))
    rs = (ci - eta * st) / (ci + eta * st)
    rp = (eta * ci - st) / (eta * ci + st)
    fresnel = 0.5 * (rs * rs + rp * rp)
    s = math.sqrt(math.pi / 8) * (0.265 * beta_n + 1.194 * beta_n ** 2 + 5.372 * beta_n ** 22)
    x = np.abs(2 * np.arcsin(h))                               # delta phi - Phi_R = 0 - (-2 gamma_i)

    def cdf(u):
        return 1 / (1 + np.exp(-u / s))

    logistic = np.exp(-x / s) / (s * (1 + np.exp(-x / s)) ** 2) / (cdf(math.pi) - cdf(-math.pi))
    return mp * fresnel * logistic


def test_one_black_fibre_matches_chiangs_r_lobe_integrated_over_its_width(mi, tmp_path):
    # a long dark fibre (only R survives: transmittance < e^-30) across a narrow view, light from
    # the eye: the image's radiance integrated over the screen is length x width x mean_h L(h)
    d, fov, W, H = 1.0, 2.0, 96, 96
    r = 2.5e-4
    cam = Camera(eye=(0, 0, d), target=(0, 0, 0), fov_y=fov)
    st = _strand(_line((-0.1, 0, 0), (0.1, 0, 0), 16), 2 * r)
    mat = HairMaterial(sigma_a=(20.0, 20.0, 20.0), longitudinal_roughness=0.3, azimuthal_roughness=0.3,
                       tilt=0.0, eta=1.55)
    E = 2.0
    img = ref.render(strands=st, camera=cam, lights=[Light("directional", (0, 0, 1), (1, 1, 1), E)],
                     settings=RenderSettings(size=(W, H)), material=mat, spp=64, cache=False)
    view = 2 * d * math.tan(math.radians(fov) / 2)             # metres across the view at the fibre
    integral = img[..., 1].sum() * (view / W) * (view / H)     # radiance x area on the fibre's plane
    h = np.linspace(-1, 1, 20001)
    expected = E * np.trapezoid(_chiang_r_backscatter(0.3, 0.3, 1.55, h), h) / 2 * view * 2 * r
    assert integral == pytest.approx(expected, rel=0.05)
    np.testing.assert_allclose(img[..., 0].sum(), img[..., 2].sum(), rtol=1e-3)   # grey: Fresnel only


@pytest.mark.parametrize("toward_light", [(0.3, 0.3, -1.0), (-0.2, 1.0, 0.0), (0.4, 1.0, 1.0)],
                         ids=["behind", "beside", "above_front"])
def test_a_blond_fibre_lit_from_any_side_has_the_far_field_radiance(mi, toward_light):
    # The scene's own path (curves, light convention, tilt, melanin) for the lobes that pass
    # through the fibre: a shadow ray from the visible side of a round tube toward a light
    # behind it must not be stopped by the tube itself (pbrt draws curves as ribbons for this),
    # or TT and TRT would be lost. The radiance integrated over the fibre's width is its width x
    # Chiang's far field f |cos theta_i| E, the NumPy twin (itself checked against Mitsuba's
    # eval, tests/test_chiang.py); the fibre runs root -> tip along +x, the eye looks down -z.
    from mane.render.shading.chiang import roughness_from_beta_m
    from mane.render.shading.melanin import melanin_to_sigma_a
    from mane.twins import chiang as C

    d, fov, W, H, r, E, tilt = 1.0, 2.0, 64, 64, 1e-3, 1.5, -2.0
    cam = Camera(eye=(0, 0, d), target=(0, 0, 0), fov_y=fov)
    sigma = melanin_to_sigma_a(0.3, 0.1)
    mat = HairMaterial(sigma_a=tuple(sigma), longitudinal_roughness=0.3, azimuthal_roughness=0.3, tilt=tilt, eta=1.55)
    st = _strand(_line((-0.1, 0, 0), (0.1, 0, 0), 16), 2 * r)
    img = ref.render(strands=st, camera=cam, lights=[Light("directional", toward_light, (1, 1, 1), E)],
                     settings=RenderSettings(size=(W, H)), material=mat, spp=128, cache=False)
    view = 2 * d * math.tan(math.radians(fov) / 2)
    measured = img.reshape(-1, 3).sum(axis=0) * (view / W) * (view / H) / (view * 2 * r)   # mean radiance on the fibre
    L = np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    theta_i = math.asin(L[0])                                   # T = +x; V = +z: theta_o = 0
    phi = math.atan2(L[1], L[2])                                # azimuth of L about the fibre from V
    expected = E * C.fibre([theta_i], [0.0], [abs(phi)], sigma, roughness=roughness_from_beta_m(0.3),
                           shift=math.radians(tilt), beta_n=0.3)[0]
    np.testing.assert_allclose(measured, expected, rtol=0.03)


def test_a_wide_fibre_shows_the_near_field_with_h_along_cross_t_v(mi):
    # A blond fibre 16 px wide lit from beside: the path tracer evaluates the hair BSDF at each
    # ray's hit offset h, and its pixels (box filter) show that near field averaged over them.
    # The twin's fibre_near with h along cross(T, V) (T root -> tip, V toward the eye) and phi
    # the light's azimuth past the eye's about -T, the convention mane's renderer follows
    # (chiang.glsl, tests/test_render_fibre_radiance.py), matches it pixel by pixel; mirrored, not.
    from mane.render.shading.chiang import roughness_from_beta_m
    from mane.render.shading.melanin import melanin_to_sigma_a
    from mane.twins import chiang as C

    d, fov, n, E, tilt = 1.0, 2.0, 64, 1.5, -2.0
    view = 2 * d * math.tan(math.radians(fov) / 2)
    px = view / n
    r = 8 * px
    a = math.radians(3.0)
    T = np.array([math.cos(a), math.sin(a), 0.0])
    sigma = melanin_to_sigma_a(0.3, 0.1)
    mat = HairMaterial(sigma_a=tuple(sigma), longitudinal_roughness=0.3, azimuthal_roughness=0.3, tilt=tilt, eta=1.55)
    st = _strand(_line(-0.1 * T, 0.1 * T, 16), 2 * r)
    L = np.array([-0.2, 1.0, 0.3]) / np.linalg.norm([-0.2, 1.0, 0.3])
    img = ref.render(strands=st, camera=Camera(eye=(0, 0, d), target=(0, 0, 0), fov_y=fov),
                     lights=[Light("directional", tuple(L), (1, 1, 1), E)], settings=RenderSettings(size=(n, n)),
                     material=mat, spp=256, cache=False)
    rows, cols = np.indices((n, n))
    side = np.cross(T, [0.0, 0.0, 1.0])[:2]                       # cross(T, V), unit here
    inside = None
    expected = mirrored = 0.0
    for dy in (np.arange(4) + 0.5) / 4 - 0.5:     # the pixel's box, 4 x 4 points (the tube's near field)
        for dx in (np.arange(4) + 0.5) / 4 - 0.5:
            X, Y = (cols + 0.5 + dx - n / 2) * px, (n / 2 - rows - 0.5 - dy) * px
            h = (X * side[0] + Y * side[1]) / r
            if inside is None:
                inside = (np.abs(h) < 0.8) & (cols >= n // 4) & (cols < 3 * n // 4)
            P = np.stack([X[inside], Y[inside], np.zeros(inside.sum())], -1)
            V = np.array([0.0, 0.0, d]) - P
            V /= np.linalg.norm(V, axis=1, keepdims=True)
            angles = C.signed_angles(np.broadcast_to(T, V.shape), V, np.broadcast_to(L, V.shape))
            for sign in (1.0, -1.0):
                f = E * C.fibre_near(*angles, sign * np.clip(h[inside], -1, 1), sigma,
                                     roughness=roughness_from_beta_m(0.3), shift=math.radians(tilt), beta_n=0.3) / 16
                if sign > 0:
                    expected = expected + f
                else:
                    mirrored = mirrored + f
    got = img[inside]
    assert np.abs(got - expected).sum() / expected.sum() < 0.05           # 0.02 measured (256 spp)
    assert np.abs(got - mirrored).sum() / mirrored.sum() > 0.5            # 1.9


def test_tilt_moves_the_highlight_as_manes_marschner_convention(mi, tmp_path):
    # a vertical fibre, root at the top, seen and lit from the front: theta_i = 0 and
    # sin theta_o = V.T, T root -> tip (down). Mane's R peaks at theta_h = alpha, i.e.
    # theta_o = 2 alpha: for alpha = -10 deg at y = d tan(2 alpha), below the centre (tipward).
    # The luminance-weighted mean of theta_o along the fibre is where the lobe sits.
    d, W, H, fov = 0.5, 16, 160, 70.0
    cam = Camera(eye=(0, 0, d), target=(0, 0, 0), fov_y=fov)
    st = _strand(_line((0, 0.33, 0), (0, -0.33, 0), 24), 0.004)
    half = d * math.tan(math.radians(fov) / 2)
    theta_o = np.degrees(np.arctan((half - (np.arange(H) + 0.5) / H * 2 * half) / d))   # per row
    for alpha in (-10.0, 10.0):
        mat = HairMaterial(sigma_a=(8.0, 8.0, 8.0), longitudinal_roughness=0.12, tilt=alpha)
        img = ref.render(strands=st, camera=cam, lights=[Light("directional", (0, 0, 1), (1, 1, 1), 1.0)],
                         settings=RenderSettings(size=(W, H)), material=mat, spp=32, cache=False)
        col = img[..., 1].sum(axis=1)
        assert (col * theta_o).sum() / col.sum() == pytest.approx(2 * alpha, abs=1.5)


def test_melanin_darkens_and_the_image_is_deterministic_and_cached(mi, tmp_path):
    cam = Camera(eye=(0, 0, 0.3), target=(0, 0, 0), fov_y=30.0)
    xs = np.linspace(-0.03, 0.03, 12)
    P = np.stack([_line((x, 0.05, 0.002 * i), (x, -0.05, 0.002 * i), 8) for i, x in enumerate(xs)])
    st = ExpandedStrands(P, np.full(P.shape[:2], 8e-4))
    light = [Light("directional", (0.3, 0.5, 1.0), (1, 1, 1), 3.0)]
    s = RenderSettings(size=(24, 24))
    kw = dict(strands=st, camera=cam, lights=light, settings=s, spp=8, cache_dir=tmp_path)
    white = ref.render(material=HairMaterial(eumelanin=0.0, pheomelanin=0.0), **kw)
    black = ref.render(material=HairMaterial(eumelanin=8.0, pheomelanin=0.0), **kw)
    assert white.mean() > 3 * black.mean() > 0
    files = sorted(p.name for p in tmp_path.glob("*.npy"))
    assert len(files) == 2
    again = ref.render(material=HairMaterial(eumelanin=8.0, pheomelanin=0.0), **kw)      # a cache hit
    np.testing.assert_array_equal(again, black)
    fresh = ref.render(material=HairMaterial(eumelanin=8.0, pheomelanin=0.0), cache=False, **kw)
    np.testing.assert_array_equal(fresh, black)                   # the same seed, the same image
    other = ref.render(material=HairMaterial(eumelanin=8.0, pheomelanin=0.0), seed=1, cache=False, **kw)
    assert not np.array_equal(other, black)
    # the key moves with anything that changes the picture
    k = ref.cache_key(material=HairMaterial(eumelanin=8.0), **{k: v for k, v in kw.items() if k != "cache_dir"})
    k2 = ref.cache_key(material=HairMaterial(eumelanin=8.0), **{**{k: v for k, v in kw.items() if k != "cache_dir"},
                                                               "spp": 9})
    assert k != k2
    # another variant is another estimator (other random numbers): another key; None is the default
    plain = {k: v for k, v in kw.items() if k != "cache_dir"}
    assert ref.cache_key(material=HairMaterial(eumelanin=8.0), variant="scalar_rgb", **plain) == k
    assert ref.cache_key(material=HairMaterial(eumelanin=8.0), variant="cuda_ad_rgb", **plain) != k


def test_a_variant_this_machine_lacks_is_one_clear_error(mi, tmp_path):
    if ref.available("cuda_ad_rgb"):
        pytest.skip("this machine renders with CUDA")
    st = _strand(_line((0, 0.05, 0), (0, -0.05, 0)), 8e-4)
    with pytest.raises(ref.ReferenceUnavailableError, match="cuda_ad_rgb") as info:
        ref.render(strands=st, camera=Camera(eye=(0, 0, 0.3), target=(0, 0, 0)), spp=1, variant="cuda_ad_rgb",
                   cache_dir=tmp_path)
    assert "\n" not in str(info.value)
    assert not list(tmp_path.iterdir())
    assert ref.mitsuba().variant() == "scalar_rgb"


def test_reference_hair_matches_the_compute_rasterisers_coverage(mi, gl, tmp_path):
    # the renderer's own expanded strands, camera and size: the path tracer's hair coverage and
    # the compute rasteriser's (its HDR alpha) agree in total and pixel by pixel
    from mane.bench.fidelity import realtime_linear
    from mane.grooming import grow
    from mane.render import Renderer
    from mane.grooming.scene import default_head

    head = default_head()
    groom = grow(head, num_strands=30, style="wavy", points_per_strand=12, seed=3)
    s = RenderSettings(size=(64, 64), strands_per_guide=8, rasterizer="compute", msaa=16, shadows="none",
                       hair_color=None, ambient=0.0, draw_head=False, width=0.002, min_pixel_width=0.0)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        strands = ref.renderer_strands(r)
        cam = r.default_camera()
        alpha = realtime_linear(r, cam, [Light()])[..., 3]
    finally:
        r.release()
    cov = ref.hair_coverage(strands=strands, camera=cam, settings=s, spp=16, cache_dir=tmp_path)
    assert alpha.sum() == pytest.approx(cov.sum(), rel=0.05)
    ys, xs = np.indices(cov.shape)
    for grid in (ys, xs):      # the same place to a quarter of a pixel (half-pixel conventions would show)
        assert (alpha * grid).sum() / alpha.sum() == pytest.approx((cov * grid).sum() / cov.sum(), abs=0.25)
    # pixel by pixel: the two samplings (a 4 x 4 grid, 16 random samples) differ by noise only
    assert np.corrcoef(alpha.ravel(), cov.ravel())[0, 1] > 0.9
    shifted = np.corrcoef(np.roll(alpha, 1, axis=1).ravel(), cov.ravel())[0, 1]
    assert shifted < np.corrcoef(alpha.ravel(), cov.ravel())[0, 1] - 0.1     # a pixel off would show


def test_render_png_writes_srgb(mi, tmp_path):
    from PIL import Image

    cam = Camera(eye=(0, 0, 0.3), target=(0, 0, 0), fov_y=30.0)
    st = _strand(_line((0, 0.05, 0), (0, -0.05, 0)), 0.004)
    img = ref.render_png(None, tmp_path / "r.png", strands=st, camera=cam, lights=[Light()],
                         settings=RenderSettings(size=(16, 12)), spp=4, cache=False)
    png = np.asarray(Image.open(tmp_path / "r.png"))
    assert png.shape == (12, 16, 3) and img.shape == (12, 16, 3) and img.dtype == np.float32
    np.testing.assert_array_equal(png, ref.to_srgb8(img))
    assert ref.to_srgb8(np.array([[[0.0, 0.0031308, 1.0]]]))[0, 0].tolist() == [0, 10, 255]


def test_cli_reference_renders_a_groom_file(mi, gl, tmp_path, capsys):
    from PIL import Image

    from mane.app.cli import main
    from mane.groom import Groom
    from mane.io import save

    P = np.stack([_line((x, 0.05, 0), (x, -0.05, 0.01), 8) for x in np.linspace(-0.02, 0.02, 5)])
    save(Groom(points=P.reshape(-1, 3).astype(np.float32), counts=np.full(5, 8, np.int32)), tmp_path / "g.hair")
    out = tmp_path / "ref.png"
    rc = main(["reference", str(tmp_path / "g.hair"), "--out", str(out), "--size", "24x16", "--spp", "2",
               "--strands-per-guide", "2", "--melanin", "0.3,0.1", "--light", "dir:0,0.5,1:3", "--cache",
               str(tmp_path / "cache")])
    assert rc == 0
    assert Image.open(out).size == (24, 16)
    assert "24x16, 2 spp, 10 strands" in capsys.readouterr().out
    assert main(["reference", str(tmp_path / "g.hair"), "--out", str(tmp_path / "x.jpg")]) == 2
    assert main(["reference", str(tmp_path / "g.hair"), "--melanin", "a,b"]) == 2


def test_hair_coverage_separates_the_hair_from_the_head_behind_and_in_front(mi, tmp_path):
    from mane.mesh import Mesh

    # a square "head" at z = 0 (x, y in +-0.05) and a wide strand across it at z = 0.01 (in
    # front, y = 0) plus one at z = -0.01 behind it (y = 0.03: hidden by the head)
    v = np.array([[-0.05, -0.05, 0], [0.05, -0.05, 0], [0.05, 0.05, 0], [-0.05, 0.05, 0]], np.float32)
    head = Mesh(vertices=v, faces=np.array([[0, 1, 2], [0, 2, 3]], np.int32))
    P = np.stack([_line((-0.08, 0.0, 0.01), (0.08, 0.0, 0.01), 8), _line((-0.08, 0.03, -0.01), (0.08, 0.03, -0.01), 8)])
    st = ExpandedStrands(P, np.full(P.shape[:2], 0.01))
    cam = Camera(eye=(0, 0, 0.4), target=(0, 0, 0), fov_y=30.0)
    s = RenderSettings(size=(40, 40))
    hair = ref.hair_coverage(strands=st, head=head, camera=cam, settings=s, spp=16, cache_dir=tmp_path)
    both = ref.hair_coverage(strands=st, head=head, camera=cam, settings=s, spp=16, cache_dir=tmp_path,
                             include_head=True)
    alone = ref.hair_coverage(strands=st, camera=cam, settings=s, spp=16, cache_dir=tmp_path)
    row = lambda y: int(round((1 - (y / (0.4 * math.tan(math.radians(15))) + 1) / 2) * 40 - 0.5))  # noqa: E731
    assert hair[row(0.0), 20] == pytest.approx(1.0) and both[row(0.0), 20] == pytest.approx(1.0)
    assert hair[row(0.03), 20] == 0.0 and alone[row(0.03), 20] == pytest.approx(1.0)   # behind the head
    assert both[row(0.03), 20] == pytest.approx(1.0) and both[row(-0.03), 20] == pytest.approx(1.0)
    assert hair[row(0.03), 8] == pytest.approx(1.0)          # beside the head (x = -0.066) it shows
    assert both[1, 1] == 0.0


def test_cli_reference_takes_the_hair_preset_and_the_frame_options(monkeypatch):
    """mane reference parses --hair like mane render, refuses it beside --melanin, and takes the
    groom and head --units/--up options (issue 13: every command that reads a groom)."""
    from mane.app.cli import build_parser
    from mane.app.reference import settings_from_args
    from mane.render.shading import hair_preset

    args = build_parser("reference").parse_args(["reference", "g.hair", "--hair", "blond", "--units", "cm",
                                                 "--up", "z", "--head-units", "mm", "--size", "8x8"])
    assert (args.units, args.up, args.head_units) == ("cm", "z", "mm")
    s = settings_from_args(args)
    assert s.shading_options["melanin"] == hair_preset("blond") and s.hair_color is None
    args = build_parser("reference").parse_args(["reference", "--hair", "red", "--melanin", "1,0"])
    with pytest.raises(UsageError, match="one of them"):
        settings_from_args(args)


def test_cli_reference_refuses_an_unknown_variant_before_any_work(tmp_path):
    """--variant is checked first: one line naming the variants, and no image written."""
    from mane.app.cli import build_parser
    from mane.app.reference import run

    out = tmp_path / "ref.png"
    args = build_parser("reference").parse_args(["reference", "--variant", "optix", "--out", str(out)])
    assert args.variant == "optix"
    with pytest.raises(UsageError, match="cuda_ad_rgb") as info:
        run(args)
    assert "\n" not in str(info.value) and not out.exists()


# ---------------------------------------------------------------- independent passes
def test_pass_seeds_and_split():
    from mane.reference.passes import pass_seed, split

    assert split(1024, 64) == [64] * 16 and split(100, 64) == [64, 36] and split(8, 64) == [8]
    assert pass_seed(5, 0) == 5                              # one pass is the plain render of its seed
    seeds = {pass_seed(s, k, a) for s in range(3) for k in range(32) for a in range(3)}
    assert len(seeds) == 3 * 32 * 3                          # no two passes or retries share a seed
    assert all(0 <= x < 2**31 for x in seeds)


def _comb():
    cam = Camera(eye=(0, 0, 0.3), target=(0, 0, 0), fov_y=30.0)
    xs = np.linspace(-0.03, 0.03, 12)
    P = np.stack([_line((x, 0.05, 0.002 * i), (x, -0.05, 0.002 * i), 8) for i, x in enumerate(xs)])
    return dict(strands=ExpandedStrands(P, np.full(P.shape[:2], 8e-4)), camera=cam,
                lights=[Light("directional", (0.3, 0.5, 1.0), (1, 1, 1), 3.0)], settings=RenderSettings(size=(24, 24)),
                material=HairMaterial(eumelanin=0.3, pheomelanin=0.1), cache=False)


def test_passes_average_to_the_many_sample_render_with_noise_falling_as_one_over_sqrt_k(mi):
    from mane.reference.passes import pass_seed

    kw = _comb()
    truth = ref.render(spp=2048, pass_spp=None, isolate=False, **kw).astype(np.float64)
    one = ref.render(spp=16, isolate=False, **kw).astype(np.float64)           # one pass of N = 16
    four = ref.render(spp=64, pass_spp=16, isolate=False, **kw).astype(np.float64)   # K = 4 passes of 16
    single64 = ref.render(spp=64, pass_spp=None, isolate=False, **kw).astype(np.float64)
    # by definition: the mean of the passes rendered alone with their seeds
    alone = np.mean([ref.render(spp=16, seed=pass_seed(0, k), isolate=False, **kw) for k in range(4)], axis=0)
    np.testing.assert_allclose(four, alone, rtol=1e-5, atol=1e-7)
    # the same expectation as one pass of K N samples: both means within 4 standard errors of
    # the 2048-sample image's (pixels are independent; hair glints make the mean itself noisy)
    for img in (four, single64):
        se = math.sqrt(((img - truth) ** 2).mean() / img.size)
        assert abs(img.mean() - truth.mean()) < 4 * se
    # independent passes: the RMS error falls by sqrt(K) = 2 (with the truth's own noise,
    # sqrt((1/16 + 1/2048) / (1/64 + 1/2048)) = 1.97); the same seed four times would give 1
    rms = lambda a: float(np.sqrt(((a - truth) ** 2).mean()))  # noqa: E731
    assert 1.6 < rms(one) / rms(four) < 2.4
    assert rms(four) == pytest.approx(rms(single64), rel=0.25)


def test_passes_run_in_child_processes_and_match_this_process(mi):
    kw = _comb()
    np.testing.assert_array_equal(ref.render(spp=8, pass_spp=4, **kw), ref.render(spp=8, pass_spp=4, isolate=False, **kw))


def test_a_crashing_pass_is_retried_with_another_seed_then_one_clear_error(mi, monkeypatch):
    from mane.reference import passes

    kw = _comb()
    # a child that segfaults whenever its seed is 0 (pass 1's first attempt), else renders
    crash_on_zero = ("import json, os, signal, sys; job = json.load(open(sys.argv[1]));"
                     "job['seed'] == 0 and os.kill(os.getpid(), signal.SIGSEGV);"
                     "from mane.reference.worker import main; sys.exit(main(sys.argv[1:]))")
    monkeypatch.setattr(passes, "WORKER", [sys.executable, "-c", crash_on_zero])
    said = []
    img = ref.render(spp=4, progress=said.append, **kw)
    assert any("SIGSEGV" in m and "another seed" in m for m in said)
    np.testing.assert_array_equal(img, ref.render(spp=4, seed=passes.pass_seed(0, 0, 1), isolate=False, **kw))
    # a child that always crashes: one line naming the pass, each seed and the signal
    monkeypatch.setattr(passes, "WORKER", [sys.executable, "-c", "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)"])
    with pytest.raises(passes.ReferencePassError) as info:
        ref.render(spp=8, pass_spp=4, **kw)
    msg = str(info.value)
    assert "\n" not in msg and "pass 1/2" in msg and msg.count("SIGSEGV") == 3 and isinstance(info.value, ManeError)
    monkeypatch.setattr(passes, "WORKER", [sys.executable, "-c", "raise SystemExit('no mitsuba here')"])
    with pytest.raises(passes.ReferencePassError, match="status 1: no mitsuba here"):
        passes.render_passes({}, 4, retries=0)


def test_passes_are_cached_one_by_one_and_reused_by_a_larger_render(mi, tmp_path):
    kw = {**_comb(), "cache": True, "cache_dir": tmp_path}
    a = ref.render(spp=8, pass_spp=4, isolate=False, **kw)
    assert len(list(tmp_path.glob("*.npy"))) == 3                   # two passes and their mean
    b = ref.render(spp=12, pass_spp=4, isolate=False, **kw)         # renders the third pass only
    assert len(list(tmp_path.glob("*.npy"))) == 5
    first = ref.render(spp=4, isolate=False, **kw)                  # pass 1 is the plain render of seed 0
    np.testing.assert_array_equal(first, ref.render(spp=4, isolate=False, **{**kw, "cache": False}))
    np.testing.assert_allclose(b, (2 * a + ref.render(spp=4, seed=ref.passes.pass_seed(0, 2), isolate=False, **kw)) / 3,
                               rtol=1e-5, atol=1e-7)


def test_the_reference_draws_the_still_pictures_points(gl):
    # the path tracer's B-spline goes through the points the still picture draws (still_segments),
    # which follow the renderer's curve far closer than a moving frame's 32 segments do: the
    # spline through each set against the curve expanded at 512 segments, on curls
    from mane.grooming import grow
    from mane.grooming.scene import default_head
    from mane.reference.scene import bspline_control_points, bspline_eval
    from mane.render import Renderer

    head = default_head()
    groom = grow(head, num_strands=20, style="curly", points_per_strand=16, seed=1)

    def expanded(**kw):
        s = RenderSettings(size=(64, 64), strands_per_guide=2, pipeline="compute", draw_head=False, **kw)
        r = Renderer(s, ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            out = ref.renderer_strands(r)
            assert r.settings is s                      # the renderer's own settings back
            return out.points
        finally:
            r.release()

    still = expanded(segments=32, still_segments=128)
    frames = expanded(segments=32, still_segments=0)
    dense = expanded(segments=512, still_segments=0)
    assert frames.shape[1] - 1 < 128 <= still.shape[1] - 1

    def off(points):
        ctrl, _ = bspline_control_points(points)
        t = np.linspace(0.0, points.shape[1] - 1, dense.shape[1])
        return np.linalg.norm(bspline_eval(ctrl, t) - dense, axis=-1)

    a, b = off(still), off(frames)
    assert np.percentile(b, 90) > 1e-4                                  # the frames' spline is off the curve
    assert np.percentile(a, 90) < 0.2 * np.percentile(b, 90), (np.percentile(a, 90), np.percentile(b, 90))
