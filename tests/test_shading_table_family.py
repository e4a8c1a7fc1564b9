"""tables="interpolated": a material's Chiang and dual-scattering tables from a grid of
absorptions (table_family.py), against the tables built exactly for that material; and the
per-context texture caches stay bounded when the material changes every frame (a data set)."""
from __future__ import annotations

import numpy as np
import pytest

from mane.render import shading as sh
from mane.render.shading import table_family as tf


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("MANE_NO_CACHE", raising=False)
    tf._memory.clear()
    yield tmp_path
    tf._memory.clear()


def _close(approx, exact, relative=True):
    """Per colour channel: within 0.5% of the table's peak anywhere and (``relative``) within 2%
    where a texel matters (above 1e-3 of the table's peak); the colourless column 3 exactly."""
    exact = exact.astype(np.float64)
    approx = approx.astype(np.float64)
    scale = np.abs(exact).max()
    for c in range(3):
        err = np.abs(approx[..., c] - exact[..., c])
        assert err.max() <= 5e-3 * scale, c
        if relative:
            assert (err / np.maximum(np.abs(exact[..., c]), 1e-3 * scale)).max() < 0.02, c
    np.testing.assert_allclose(approx[..., 3], exact[..., 3], rtol=1e-5, atol=1e-7)


# melanin of the presets' range (blond to black) and one between grid values of every channel
MATERIALS = [(0.3, 0.1), (1.3, 0.2), (6.5, 1.3)]


@pytest.mark.parametrize("melanin", MATERIALS)
def test_interpolated_chiang_table_matches_exact(fresh_cache, melanin):
    exact = sh.ShadingSettings(melanin=melanin, chiang_size=16)
    approx = sh.ShadingSettings(melanin=melanin, chiang_size=16, tables="interpolated")
    _close(approx.chiang_table(), exact.chiang_table())


@pytest.mark.parametrize("melanin", MATERIALS[:2])
def test_interpolated_dual_lut_matches_exact(fresh_cache, melanin):
    exact = sh.ShadingSettings(melanin=melanin, dual_size=16)
    approx = sh.ShadingSettings(melanin=melanin, dual_size=16, tables="interpolated")
    from mane.render.shading.dual_scattering import ROW_DELTA_B

    a, e = approx.dual_lut(), exact.dual_lut()
    for row in range(e.shape[0]):   # each row its own quantity
        if row == ROW_DELTA_B:   # a signed angle: within a tenth of a degree
            assert np.abs(a[row, :, :3] - e[row, :, :3]).max() < np.radians(0.1)
        else:
            _close(a[row], e[row])


def test_grid_values_are_exact_and_come_back_from_disk(fresh_cache):
    sigma = (tf.GRID[5], tf.GRID[20], tf.GRID[40])
    s = sh.ShadingSettings(sigma_a=sigma, chiang_size=8, tables="interpolated")
    exact = sh.ShadingSettings(sigma_a=sigma, chiang_size=8).chiang_table()
    first = s.chiang_table()
    np.testing.assert_allclose(first, exact, rtol=1e-5, atol=1e-8)
    files = sorted(p.name for p in (fresh_cache / "mane" / "tables").glob("chiang-*.npz"))
    assert len(files) == 6   # each channel's grid value and its upper neighbour
    tf._memory.clear()

    def build(x):
        raise AssertionError("built again: the disk cache was not read")

    key = s.chiang_key()   # (sigma_a as the renderer keys it, eta, beta_n, size)
    again = tf.interpolated("chiang", key[1:], key[0], build)
    np.testing.assert_array_equal(again, first)


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_bad_absorption_is_refused(bad):
    with pytest.raises(ValueError, match="absorption"):
        tf.bracket(bad)


def test_unknown_tables_mode_is_refused():
    with pytest.raises(ValueError, match="tables must be one of"):
        sh.ShadingSettings(tables="fast")


def test_texture_caches_stay_bounded(gl):
    """40 materials drawn one after the other (a data set's samples) keep at most
    TEXTURES_PER_CONTEXT textures of each kind alive, and release the rest."""
    made = []
    for i in range(40):
        s = sh.ShadingSettings(sigma_a=(0.1 + 0.05 * i, 0.5, 1.0), chiang_size=8, dual_size=8)
        made.append(sh.chiang_texture(gl, s))
    cache = sh._chiang_cache[gl]
    assert len(cache) == sh.TEXTURES_PER_CONTEXT
    released = [type(t.mglo).__name__ == "InvalidObject" for t in made]
    assert sum(released) == 40 - sh.TEXTURES_PER_CONTEXT
    assert not any(released[-sh.TEXTURES_PER_CONTEXT:])


def test_dataset_samples_use_interpolated_tables(tmp_path):
    from mane.dataset.spec import parse_spec

    spec = parse_spec({"name": "t", "samples": 1, "size": [32, 32], "grooms": [{"style": "straight", "strands": 10}]},
                      str(tmp_path))
    assert spec.render_settings().shading_options["tables"] == "interpolated"
    mine = parse_spec({"name": "t", "samples": 1, "size": [32, 32], "grooms": [{"style": "straight", "strands": 10}],
                       "render": {"shading_options": {"tables": "exact"}}}, str(tmp_path))
    assert mine.render_settings().shading_options["tables"] == "exact"

