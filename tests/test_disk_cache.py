"""mane.disk_cache: results of pure functions on disk, keyed by every input; a changed input
reads another file, a damaged file is ignored with a warning and built again."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from mane import disk_cache


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("MANE_NO_CACHE", raising=False)
    return tmp_path


class Build:
    """A build that counts its calls."""

    def __init__(self, *arrays):
        self.arrays, self.calls = arrays, 0

    def __call__(self):
        self.calls += 1
        return self.arrays


def test_root_is_the_user_cache_dir(cache_home, monkeypatch):
    assert disk_cache.root() == cache_home / "mane"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(cache_home / "home"))
    assert disk_cache.root() == cache_home / "home" / ".cache" / "mane"
    monkeypatch.setenv("MANE_NO_CACHE", "1")
    assert disk_cache.root() is None


def test_digest_covers_values_dtype_and_shape():
    a = np.arange(6, dtype=np.float32)
    assert disk_cache.digest(a, 1) == disk_cache.digest(a.copy(), 1)
    others = [disk_cache.digest(a + np.float32(1e-6), 1), disk_cache.digest(a.astype(np.float64), 1),
              disk_cache.digest(a.reshape(2, 3), 1), disk_cache.digest(a, 2), disk_cache.digest(a, 1.0),
              disk_cache.digest(a, "1")]
    assert len({disk_cache.digest(a, 1), *others}) == 1 + len(others)


def test_built_once_then_read(cache_home):
    values = (np.linspace(0, 1, 7, dtype=np.float32), np.array([1.5, -2.0]), np.array(0.25))
    build = Build(*values)
    first = disk_cache.arrays("unit", "k1", build)
    again = disk_cache.arrays("unit", "k1", Build())          # not built: read from the file
    assert build.calls == 1
    assert (cache_home / "mane" / "unit" / "k1.npz").is_file()
    for a, b, want in zip(first, again, values):
        assert b.dtype == want.dtype and b.shape == want.shape
        np.testing.assert_array_equal(b, want)
        np.testing.assert_array_equal(a, want)


def test_another_key_builds_again(cache_home):
    disk_cache.arrays("unit", "k1", Build(np.zeros(3)))
    other = Build(np.ones(3))
    got = disk_cache.arrays("unit", "k2", other)
    assert other.calls == 1
    np.testing.assert_array_equal(got[0], np.ones(3))


@pytest.mark.parametrize("damage", [b"", b"not an npz at all", "truncate", "other arrays"])
def test_a_damaged_file_is_ignored_with_a_warning(cache_home, damage):
    want = np.arange(1000, dtype=np.float64)
    disk_cache.arrays("unit", "k", Build(want))
    file = disk_cache.path("unit", "k")
    if damage == "truncate":
        file.write_bytes(file.read_bytes()[:200])
    elif damage == "other arrays":
        np.savez(file, something=np.zeros(2))
    else:
        file.write_bytes(damage)
    build = Build(want)
    with pytest.warns(RuntimeWarning, match="unreadable cache file"):
        got = disk_cache.arrays("unit", "k", build)
    assert build.calls == 1
    np.testing.assert_array_equal(got[0], want)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                         # written again: read cleanly
        np.testing.assert_array_equal(disk_cache.arrays("unit", "k", Build())[0], want)


def test_no_cache_builds_every_time(cache_home, monkeypatch):
    monkeypatch.setenv("MANE_NO_CACHE", "1")
    build = Build(np.zeros(2))
    disk_cache.arrays("unit", "k", build)
    disk_cache.arrays("unit", "k", build)
    assert build.calls == 2
    assert not (cache_home / "mane").exists()


def test_an_unwritable_cache_still_builds(cache_home):
    (cache_home / "mane").write_text("a file where the folder should be")
    got = disk_cache.arrays("unit", "k", Build(np.ones(2)))
    np.testing.assert_array_equal(got[0], np.ones(2))
