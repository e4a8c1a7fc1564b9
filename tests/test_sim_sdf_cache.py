"""MeshSDF.bake reads a field baked before from the disk cache (mane.disk_cache): the same field
as a fresh bake, baked again when the mesh, the resolution, the padding or the bake's code
differ, and a damaged file is ignored with a warning."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from mane.sim import sdf as sdf_mod
from mane.sim.sdf import MeshSDF


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("MANE_NO_CACHE", raising=False)
    return tmp_path


@pytest.fixture
def bakes(monkeypatch):
    """The arguments of every real bake (sdf.bake_sdf) from here on."""
    calls, real = [], sdf_mod.bake_sdf

    def counted(vertices, faces, resolution=64, padding=0.05):
        calls.append((np.array(vertices), resolution, padding))
        return real(vertices, faces, resolution, padding)

    monkeypatch.setattr(sdf_mod, "bake_sdf", counted)
    return calls


@pytest.fixture(scope="module")
def sphere():
    m = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    return np.asarray(m.vertices, np.float32), np.asarray(m.faces, np.int32)


def _same(sdf, values, lo, h):
    np.testing.assert_array_equal(sdf.values, values)
    np.testing.assert_array_equal(sdf.lo, lo)
    assert sdf.h == h


def test_second_bake_is_read_and_equal(cache_home, bakes, sphere):
    first = MeshSDF.bake(None, sphere, resolution=16, padding=0.05)
    second = MeshSDF.bake(None, sphere, resolution=16, padding=0.05)
    assert len(bakes) == 1
    values, lo, h = sdf_mod.bake_sdf(*sphere, 16, 0.05)       # a fresh bake, the golden
    _same(first, values, lo, h)
    _same(second, values, lo, h)
    assert len(list((cache_home / "mane" / "sdf").glob("*.npz"))) == 1


@pytest.mark.parametrize("change", ["moved", "resolution", "padding", "faces", "code"])
def test_a_changed_input_bakes_again(cache_home, bakes, sphere, monkeypatch, change):
    MeshSDF.bake(None, sphere, resolution=16, padding=0.05)
    v, f, res, pad = sphere[0], sphere[1], 16, 0.05
    if change == "moved":
        v = v + np.float32(0.01)
    elif change == "resolution":
        res = 17
    elif change == "padding":
        pad = 0.06
    elif change == "faces":
        f = f[:, [0, 2, 1]]                                   # the same triangles wound the other way
    else:
        monkeypatch.setattr(sdf_mod, "_CODE", "another bake")
    got = MeshSDF.bake(None, (v, f), resolution=res, padding=pad)
    assert len(bakes) == 2
    _same(got, *sdf_mod.bake_sdf(v, f, res, pad))


def test_a_damaged_file_is_baked_again_with_a_warning(cache_home, bakes, sphere):
    MeshSDF.bake(None, sphere, resolution=16, padding=0.05)
    (file,) = (cache_home / "mane" / "sdf").glob("*.npz")
    file.write_bytes(file.read_bytes()[: file.stat().st_size // 2])
    with pytest.warns(RuntimeWarning, match="unreadable cache file"):
        got = MeshSDF.bake(None, sphere, resolution=16, padding=0.05)
    assert len(bakes) == 2
    _same(got, *sdf_mod.bake_sdf(*sphere, 16, 0.05))
