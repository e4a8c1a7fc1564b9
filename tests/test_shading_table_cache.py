"""A material's exact shading tables (Chiang azimuthal table, dual-scattering LUT, Marschner
LUTs) come back from the disk cache (mane.disk_cache) equal to a fresh build by the table
modules; another material, size or table code builds again; a damaged file is ignored with a
warning."""
from __future__ import annotations

import numpy as np
import pytest

from mane.render import shading as sh
from mane.render.shading import table_family as tf
from mane.render.shading.chiang import azimuthal_table
from mane.render.shading.dual_scattering import build_dual_lut
from mane.render.shading.luts import build_marschner_luts


def _forget():
    for f in (sh._chiang_table, sh._dual_lut, sh._dual_tables):
        getattr(f, "cache_clear", lambda: None)()     # a test may have patched one


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("MANE_NO_CACHE", raising=False)
    _forget()
    yield tmp_path
    _forget()


@pytest.fixture
def chiang_builds(monkeypatch):
    calls, real = [], sh._build_chiang_table

    def counted(key):
        calls.append(key)
        return real(key)

    monkeypatch.setattr(sh, "_build_chiang_table", counted)
    return calls


def _chiang_golden(s):
    return azimuthal_table(np.round(s.resolved_sigma_a(), 9), eta=s.eta, beta_n=s.beta_n,
                           n_phi=2 * s.chiang_size, n_theta=s.chiang_size)


def test_chiang_table_is_read_back_equal(cache_home, chiang_builds):
    s = sh.ShadingSettings(melanin=(1.3, 0.2), chiang_size=8)
    first = s.chiang_table()
    _forget()                                  # a new process: only the disk remembers
    again = s.chiang_table()
    assert len(chiang_builds) == 1
    assert len(list((cache_home / "mane" / "chiang").glob("*.npz"))) == 1
    golden = _chiang_golden(s)
    assert again.dtype == first.dtype == golden.dtype
    np.testing.assert_array_equal(first, golden)
    np.testing.assert_array_equal(again, golden)


@pytest.mark.parametrize("change", [dict(melanin=(1.3, 0.21)), dict(chiang_size=9), dict(eta=1.5),
                                    dict(beta_n=0.4), "code"])
def test_chiang_table_changed_input_builds_again(cache_home, chiang_builds, monkeypatch, change):
    sh.ShadingSettings(melanin=(1.3, 0.2), chiang_size=8).chiang_table()
    _forget()
    if change == "code":
        monkeypatch.setattr(tf, "CODE", "another builder")
        s = sh.ShadingSettings(melanin=(1.3, 0.2), chiang_size=8)
    else:
        s = sh.ShadingSettings(**{"melanin": (1.3, 0.2), "chiang_size": 8, **change})
    got = s.chiang_table()
    assert len(chiang_builds) == 2
    np.testing.assert_array_equal(got, _chiang_golden(s))


def test_damaged_table_file_is_built_again_with_a_warning(cache_home, chiang_builds):
    s = sh.ShadingSettings(melanin=(6.5, 1.3), chiang_size=8)
    s.chiang_table()
    _forget()
    (file,) = (cache_home / "mane" / "chiang").glob("*.npz")
    file.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.warns(RuntimeWarning, match="unreadable cache file"):
        got = s.chiang_table()
    assert len(chiang_builds) == 2
    np.testing.assert_array_equal(got, _chiang_golden(s))


def test_dual_lut_is_read_back_equal(cache_home, monkeypatch):
    s = sh.ShadingSettings(melanin=(1.3, 0.2), dual_size=8, chiang_size=8)
    golden = build_dual_lut(sh.ShadingSettings(melanin=(1.3, 0.2), dual_size=8, chiang_size=8).dual_tables())
    _forget()
    first = s.dual_lut()
    _forget()
    monkeypatch.setattr(sh, "_dual_tables", lambda key: pytest.fail("built again: the disk was not read"))
    again = s.dual_lut()
    np.testing.assert_array_equal(first, golden)
    np.testing.assert_array_equal(again, golden)
    other = sh.ShadingSettings(melanin=(1.3, 0.2), dual_size=8, chiang_size=8, dual_density_back=0.5)
    with pytest.raises(pytest.fail.Exception):
        other.dual_lut()                       # another material: not in the cache, built


def test_marschner_luts_are_read_back_equal(cache_home, monkeypatch):
    s = sh.ShadingSettings(model="marschner_lut", melanin=(1.3, 0.2), lut_size=16)
    golden = build_marschner_luts(s.resolved_sigma_a(), eta=s.eta, beta_r=s.roughness, alpha_r=s.shift,
                                  glint=s.glint, caustic_width=s.caustic_width, caustic_fade=s.caustic_fade,
                                  caustic_limit=s.caustic_limit, size=s.lut_size)
    first = s.luts()
    import mane.render.shading.luts as luts

    monkeypatch.setattr(luts, "build_marschner_luts", lambda *a, **k: pytest.fail("built again"))
    again = s.luts()
    assert len(first) == len(again) == len(golden) == 2
    for a, b, g in zip(first, again, golden):
        np.testing.assert_array_equal(a, g)
        np.testing.assert_array_equal(b, g)
    with pytest.raises(pytest.fail.Exception):
        sh.ShadingSettings(model="marschner_lut", melanin=(1.3, 0.2), lut_size=16, shift=-0.05).luts()
