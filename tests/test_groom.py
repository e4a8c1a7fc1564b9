"""The groom model's invariants and transforms, checked against direct NumPy computation."""
import numpy as np
import pytest

from mane import Groom, GroomError, UsageError
from mane.groom import up_axis_matrix


def two_strands():
    a = np.array([[0, 0, 0], [0, 1, 0], [0, 3, 0]], np.float32)  # lengths 1, 2
    b = np.array([[1, 0, 0], [1, 0, 2]], np.float32)  # length 2
    return Groom.from_strands([a, b], widths=np.arange(5, dtype=np.float32))


def test_offsets_and_counts():
    g = two_strands()
    assert g.offsets.tolist() == [0, 3, 5]
    assert g.offsets.dtype == np.int64 and g.counts.dtype == np.int32 and g.points.dtype == np.float32
    assert g.num_segments == 3
    assert g.segment_lengths().tolist() == [1.0, 2.0, 2.0]
    assert g.strand_lengths().tolist() == [3.0, 2.0]
    assert g.strand_of_point().tolist() == [0, 0, 0, 1, 1]
    np.testing.assert_array_equal(g.roots, [[0, 0, 0], [1, 0, 0]])
    np.testing.assert_array_equal(g.tips, [[0, 3, 0], [1, 0, 2]])


@pytest.mark.parametrize(
    "points,counts,msg",
    [
        (np.zeros((3, 3)), [3, 0], "at least 2"),
        (np.zeros((3, 3)), [1, 2], "at least 2"),
        (np.zeros((4, 3)), [2, 3], "add up to 5"),
        (np.array([[0, 0, 0], [np.nan, 0, 0]]), [2], "not finite"),
        (np.array([[0, 0, 0], [np.inf, 0, 0]]), [2], "not finite"),
        (np.zeros((4, 2)), [2, 2], "shape"),
        (np.zeros((0, 3)), [], "no strands"),
    ],
)
def test_invalid_grooms_raise(points, counts, msg):
    with pytest.raises(GroomError, match=msg):
        Groom(points, np.asarray(counts))


def test_bad_attribute_lengths():
    with pytest.raises(GroomError, match="widths"):
        Groom(np.zeros((2, 3)), [2], widths=np.zeros(3))
    with pytest.raises(GroomError, match="strand attribute"):
        Groom(np.zeros((2, 3)), [2], strand_attributes={"uv": np.zeros((2, 2))})
    with pytest.raises(GroomError, match="NaN"):
        Groom(np.zeros((2, 3)), [2], colors=np.full((2, 3), np.nan))


def test_up_axis_is_a_proper_rotation():
    for a in "xyz":
        for b in "xyz":
            m = up_axis_matrix(a, b)[:3, :3]
            assert np.isclose(np.linalg.det(m), 1.0)
            np.testing.assert_array_equal(m @ np.eye(3)["xyz".index(a)], np.eye(3)["xyz".index(b)])
    g = two_strands().with_up_axis("z")
    np.testing.assert_allclose(g.strand(1), [[1, 0, 0], [1, 2, 0]], atol=1e-7)
    with pytest.raises(UsageError):
        up_axis_matrix("w")


def test_scale_translate():
    g = two_strands()
    s = g.scaled(2.0)
    np.testing.assert_allclose(s.points, g.points * 2)
    np.testing.assert_allclose(s.widths, g.widths * 2)
    t = g.translated([1, 2, 3])
    np.testing.assert_allclose(t.points, g.points + [1, 2, 3])
    with pytest.raises(UsageError):
        g.scaled(-1)


def test_subset_keeps_attributes():
    g = two_strands()
    g.strand_attributes["id"] = np.array([10, 20])
    s = g.subset([1, 0])
    np.testing.assert_array_equal(s.strand(0), g.strand(1))
    np.testing.assert_array_equal(s.strand(1), g.strand(0))
    assert s.widths.tolist() == [3, 4, 0, 1, 2]
    assert s.strand_attributes["id"].tolist() == [20, 10]
    assert g.subset(np.array([False, True])).num_strands == 1
    with pytest.raises(GroomError):
        g.subset([])


def test_resample_is_uniform_in_arc_length():
    rng = np.random.default_rng(0)
    strands = [np.cumsum(rng.normal(size=(n, 3)), axis=0) for n in (2, 5, 17, 40)]
    g = Groom.from_strands(strands, point_attributes={"fixed": np.zeros(64, bool)})
    r = g.resampled(11)
    assert r.counts.tolist() == [11] * 4
    for s, src in enumerate(strands):
        seg = np.linalg.norm(np.diff(r.strand(s), axis=0), axis=1)
        # every resampled point lies on the polyline; spacing along the polyline is total/10,
        # so chords are at most that and the polyline's length is preserved at the ends
        total = np.linalg.norm(np.diff(src, axis=0), axis=1).sum()
        assert np.all(seg <= total / 10 * (1 + 1e-5))
        np.testing.assert_allclose(r.strand(s)[0], src[0], rtol=1e-6)
        np.testing.assert_allclose(r.strand(s)[-1], src[-1], rtol=1e-5, atol=1e-5)
    # a straight strand keeps exact equal spacing
    line = Groom(np.array([[0, 0, 0], [0, 0.1, 0], [0, 1, 0]], np.float32), [3])
    np.testing.assert_allclose(line.resampled(5).points[:, 1], [0, 0.25, 0.5, 0.75, 1.0], atol=1e-7)
    assert r.point_attributes["fixed"].dtype == bool


def test_zero_length_segments_removed_and_reported():
    pts = np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0], [5, 5, 5], [5, 5, 5], [0, 0, 0], [0, 2, 0]], np.float32)
    g = Groom(pts, [3, 2, 2])
    assert g.stats()["zero_length_segments"] == 2
    c = g.without_zero_length_segments()
    assert c.counts.tolist() == [2, 2]
    assert c.metadata["cleaned"] == {"removed_points": 3, "removed_strands": 1}
    assert c.stats()["zero_length_segments"] == 0


def test_stats_values():
    st = two_strands().stats()
    assert st["num_strands"] == 2 and st["num_points"] == 5
    assert st["points_per_strand"] == {"min": 2, "max": 3, "mean": 2.5}
    assert st["bbox"] == {"min": [0.0, 0.0, 0.0], "max": [1.0, 3.0, 2.0]}
    assert st["strand_length"]["max"] == 3.0


def test_concatenate():
    g = two_strands()
    c = Groom.concatenate([g, g.translated([0, 0, 1])])
    assert c.num_strands == 4 and c.widths is not None
    assert c.equals(Groom.concatenate([g, g.translated([0, 0, 1])]))
