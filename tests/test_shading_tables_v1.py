"""The shading tables vectorised over the fibre offset h (chiang.azimuthal_grid, one set of
hemisphere integrals for both dual-scattering grids) against the loops they replaced, kept
verbatim in tests/shading_tables_v1.py: the float64 integrals to ~1e-12, the float32 tables
the shaders read to rtol 1e-5 / atol 1e-7 (in practice bit for bit)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import shading_tables_v1 as v1
from mane.render.shading import ShadingSettings, chiang
from mane.render.shading import dual_scattering as D
from mane.render.shading.melanin import melanin_to_sigma_a

DEFAULT = ShadingSettings()
MATERIALS = {   # (sigma_a, eta, beta_n)
    "default": (np.asarray(DEFAULT.chiang_key()[0]), DEFAULT.eta, DEFAULT.beta_n),
    "white": (np.zeros(3), 1.55, 0.3),
    "black": (melanin_to_sigma_a(8.0, 0.5), 1.55, 0.3),
    "rough": (melanin_to_sigma_a(0.4, 0.6), 1.45, 0.8),
    "sharp": (melanin_to_sigma_a(1.3, 0.2), 1.6, 0.12),
}


@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_chiang_table_matches_the_loop(name):
    sigma_a, eta, beta_n = MATERIALS[name]
    size = 64 if name == "default" else 16
    new = chiang.azimuthal_table(sigma_a, eta=eta, beta_n=beta_n, n_phi=2 * size, n_theta=size)
    old = v1.azimuthal_table(sigma_a, eta=eta, beta_n=beta_n, n_phi=2 * size, n_theta=size)
    assert new.dtype == np.float32 and new.shape == old.shape
    np.testing.assert_allclose(new, old, rtol=1e-5, atol=1e-7)
    assert np.ptp(new[:, 4 * size:, :3], axis=1).max() == 0.0     # Nbar_3: constant along phi


@pytest.mark.parametrize("case", ["points", "wide_phi", "narrow_logistic"])
def test_azimuthal_average_off_the_table_paths(case):
    """Not a grid (one theta_o at a time), phi outside [0, pi] and a logistic too narrow for the
    product form (both: the exponential per value) against the loop, float64."""
    rng = np.random.default_rng(7)
    sigma_a = melanin_to_sigma_a(1.3, 0.2)
    phi = rng.uniform(0.0, math.pi, 40)
    theta = rng.uniform(-1.5, 1.5, 40)
    beta_n = 0.3
    if case == "wide_phi":
        phi = rng.uniform(-7.0, 7.0, (5, 8))
        theta = np.linspace(0.0, 1.4, 8)
    elif case == "narrow_logistic":
        beta_n = 0.026                                  # pi / s = 651 > 600
        phi, theta = np.meshgrid(np.linspace(0, math.pi, 9), np.linspace(0, 1.4, 4))
    new = chiang.azimuthal_average(phi, theta, sigma_a, beta_n=beta_n, n_h=64)
    old = v1.azimuthal_average(phi, theta, sigma_a, beta_n=beta_n, n_h=64)
    for a, b in zip(new, old):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-14)


def test_hemisphere_integrals_match_the_loop():
    theta = np.array([-1.2, -0.3, 0.0, 0.3, 0.7, 1.5])
    sigma_a = melanin_to_sigma_a(1.3, 0.2)
    for new, old in zip(D.chiang_hemisphere_integrals(theta, sigma_a, specular=0.7, n_phi=32, n_h=64),
                        v1.chiang_hemisphere_integrals(theta, sigma_a, specular=0.7, n_phi=32, n_h=64)):
        np.testing.assert_allclose(new, old, rtol=1e-11, atol=1e-15)


@pytest.mark.parametrize("name,size,specular", [("default", 64, 1.0), ("black", 9, 0.6), ("rough", 16, 1.3)])
def test_dual_tables_match_the_loop(name, size, specular):
    sigma_a, eta, beta_n = MATERIALS[name]
    kw = dict(eta=eta, roughness=DEFAULT.roughness, shift=DEFAULT.shift, beta_n=beta_n, specular=specular,
              d_b=DEFAULT.dual_density_back)
    new = D._precompute_dual_chiang(sigma_a, size, **kw)
    old = v1._precompute_dual_chiang(sigma_a, size, **kw)
    for f in dataclasses.fields(old):
        np.testing.assert_allclose(getattr(new, f.name), getattr(old, f.name), rtol=1e-9, atol=1e-15,
                                   err_msg=f.name)
    np.testing.assert_allclose(D.build_dual_lut(new), D.build_dual_lut(old), rtol=1e-5, atol=1e-7)


def test_the_default_materials_textures_match_the_loop(monkeypatch):
    """What the renderer binds (ShadingSettings.chiang_table / dual_lut, cache off)."""
    from mane.render import shading

    monkeypatch.setenv("MANE_NO_CACHE", "1")
    shading._chiang_table.cache_clear()
    shading._dual_lut.cache_clear()
    shading._dual_tables.cache_clear()
    s = ShadingSettings()
    sigma_a, eta, beta_n, size = s.chiang_key()
    np.testing.assert_allclose(s.chiang_table(), v1.azimuthal_table(np.asarray(sigma_a), eta=eta, beta_n=beta_n,
                                                                     n_phi=2 * size, n_theta=size),
                               rtol=1e-5, atol=1e-7)
    old = v1._precompute_dual_chiang(np.asarray(sigma_a), s.dual_size, eta=s.eta, roughness=s.roughness,
                                     shift=s.shift, beta_n=s.beta_n, specular=s.specular,
                                     d_b=s.dual_density_back)
    np.testing.assert_allclose(s.dual_lut(), D.build_dual_lut(old), rtol=1e-5, atol=1e-7)
