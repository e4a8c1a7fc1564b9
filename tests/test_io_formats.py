"""Binary and text hair formats against files built from the spec with struct/NumPy.

Golden values come from the spec (../shared/research/formats.md) and NumPy, never from the
code under test: files are assembled byte by byte here, and written files are parsed here.
"""
from __future__ import annotations

import json
import struct
import zipfile

import numpy as np
import pytest

import mane
from mane import FormatError, Groom, GroomError, ManeError, UnsupportedFormatError
from mane.groom import up_axis_matrix
from mane.io import cyhair, strand_ply, usc_hairsalon
from test_io_helpers import cyhair_bytes, sample_groom, tfx3_bytes, tfx4_bytes, usc_bytes

Z_TO_Y = up_axis_matrix("z", "y")[:3, :3]


def load_raw(path, **kw):
    """The file's numbers as stored (metres, Y up asserted): these tests read formats, not units."""
    return mane.load(path, units="m", up="y", **kw)


def z_up_to_y(p):
    return (np.asarray(p, np.float64) @ Z_TO_Y.T).astype(np.float32)


# ----------------------------------------------------------------------------- cyHair
def test_cyhair_all_arrays(tmp_path):
    rng = np.random.default_rng(1)
    counts = [3, 2, 4]
    pts = rng.normal(size=(9, 3)).astype(np.float32)
    th, tr, co = rng.random(9), rng.random(9), rng.random((9, 3))
    f = tmp_path / "a.hair"
    f.write_bytes(cyhair_bytes(pts, counts, thickness=th, transparency=tr, colors=co, info=b"hello"))
    g = mane.load(f)
    assert g.counts.tolist() == counts
    np.testing.assert_array_equal(g.points, z_up_to_y(pts))
    np.testing.assert_array_equal(g.widths, th.astype(np.float32))
    np.testing.assert_array_equal(g.transparency, tr.astype(np.float32))
    np.testing.assert_array_equal(g.colors, co.astype(np.float32))
    m = g.metadata["cyhair"]
    assert m["info"] == "hello" and m["defaults_used"] == [] and m["up_axis"] == "z"
    assert m["arrays"] == ["segments", "points", "thickness", "transparency", "colors"]
    # Z up becomes Y up: a strand along +z in the file goes along +y.
    assert np.allclose(Z_TO_Y @ [0, 0, 1], [0, 1, 0])


def test_cyhair_header_defaults(tmp_path):
    pts = np.arange(24, dtype=np.float32).reshape(8, 3)
    f = tmp_path / "d.hair"
    f.write_bytes(cyhair_bytes(pts, None, d_segments=3, d_thickness=0.5, d_transparency=0.25,
                               d_color=(0.1, 0.2, 0.3)))
    g = cyhair.read(f, up="y")
    assert g.counts.tolist() == [4, 4]
    np.testing.assert_array_equal(g.points, pts)
    assert np.all(g.widths == np.float32(0.5)) and np.all(g.transparency == np.float32(0.25))
    np.testing.assert_array_equal(g.colors, np.tile(np.float32([0.1, 0.2, 0.3]), (8, 1)))
    assert sorted(g.metadata["cyhair"]["defaults_used"]) == ["colors", "thickness", "transparency"]


def test_cyhair_d_segments_must_match_point_count(tmp_path):
    pts = np.zeros((8, 3), np.float32)
    f = tmp_path / "bad.hair"
    f.write_bytes(cyhair_bytes(pts, None, d_segments=2, hair_count=2))  # 2*(2+1)=6 != 8
    with pytest.raises(FormatError, match="d_segments"):
        mane.load(f)


@pytest.mark.parametrize("mutate,msg", [
    (lambda b: b"HAIX" + b[4:], "signature"),
    (lambda b: b[:100], "128-byte header"),
    (lambda b: b[:-4], "truncated"),
    (lambda b: b + b"\0\0\0\0", "trailing"),
    (lambda b: b[:4] + struct.pack("<I", 0xFFFFFFFF) + b[8:], "truncated"),  # absurd strand count
    (lambda b: b[:8] + struct.pack("<I", 0x7FFFFFFF) + b[12:], "truncated"),  # absurd point count
    (lambda b: b[:12] + struct.pack("<I", 0x21) + b[16:], "unknown bits"),
    (lambda b: b[:12] + struct.pack("<I", 0x1) + b[16:], "no points array"),
])
def test_cyhair_refuses(tmp_path, mutate, msg):
    good = cyhair_bytes(np.ones((5, 3)), [3, 2])
    f = tmp_path / "x.hair"
    f.write_bytes(mutate(good))
    with pytest.raises(FormatError, match=msg) as err:
        mane.load(f)
    assert str(f) in str(err.value)


def test_cyhair_nan_names_offset(tmp_path):
    pts = np.ones((5, 3), np.float32)
    pts[1, 2] = np.nan
    f = tmp_path / "n.hair"
    f.write_bytes(cyhair_bytes(pts, [3, 2]))
    with pytest.raises(FormatError, match="non-finite") as err:
        mane.load(f)
    assert err.value.offset == 128 + 2 * 2 + (3 + 2) * 4  # header, segments, 5 floats in


def test_cyhair_segments_sum_checked(tmp_path):
    f = tmp_path / "s.hair"
    f.write_bytes(cyhair_bytes(np.ones((5, 3)), [3, 3], point_count=5)[:-0 or None])
    with pytest.raises(FormatError):
        mane.load(f)


def test_cyhair_single_point_strands_dropped(tmp_path):
    f = tmp_path / "one.hair"
    f.write_bytes(cyhair_bytes(np.arange(18, dtype=np.float32).reshape(6, 3), [3, 1, 2]))
    g = cyhair.read(f, up="y")
    assert g.counts.tolist() == [3, 2]
    np.testing.assert_array_equal(g.points[3], [12, 13, 14])
    assert g.metadata["cyhair"]["dropped_single_point_strands"] == 1


def test_cyhair_writer_layout(tmp_path):
    g = sample_groom([3, 2, 4])
    f = tmp_path / "w.hair"
    cyhair.write(g, f, up="y", info="mane test")
    raw = f.read_bytes()
    assert raw[:4] == b"HAIR"
    hc, pc, arrays, dseg = struct.unpack_from("<4I", raw, 4)
    assert (hc, pc, arrays) == (3, 9, 0b11111)
    assert raw[40:67] == b"mane units=m up=y; mane test"[:27]   # the declaration, then the text
    assert cyhair.read(f, up="y").metadata["cyhair"]["info"] == "mane test"
    seg = np.frombuffer(raw, "<u2", 3, 128)
    assert seg.tolist() == [2, 1, 3]
    np.testing.assert_array_equal(np.frombuffer(raw, "<f4", 27, 134).reshape(9, 3), g.points)
    assert len(raw) == 128 + 6 + 9 * (12 + 4 + 4 + 12)


def test_cyhair_compact_writer_uses_defaults(tmp_path):
    g = Groom(np.arange(24, dtype=np.float32).reshape(8, 3), [4, 4],
              widths=np.full(8, 0.3, np.float32), colors=np.tile([0.5, 0.25, 1.0], (8, 1)))
    f = tmp_path / "c.hair"
    cyhair.write(g, f, up="y")
    raw = f.read_bytes()
    hc, pc, arrays, dseg = struct.unpack_from("<4I", raw, 4)
    assert arrays == 0b10 and dseg == 3 and len(raw) == 128 + 8 * 12
    assert struct.unpack_from("<f", raw, 20)[0] == np.float32(0.3)
    back = cyhair.read(f, up="y")
    assert back.equals(g.replace(transparency=np.zeros(8, np.float32)))


# ----------------------------------------------------------------------------- USC-HairSalon
def test_usc_empty_slots_kept(tmp_path):
    a = np.arange(9, dtype=np.float32).reshape(3, 3)
    b = np.arange(6, dtype=np.float32).reshape(2, 3) + 100
    single = np.float32([[7, 8, 9]])
    f = tmp_path / "h.data"
    raw = usc_bytes([a, single, np.zeros((0, 3)), b])
    f.write_bytes(raw)
    g = load_raw(f)
    assert g.counts.tolist() == [3, 2]
    np.testing.assert_array_equal(g.points, np.concatenate([a, b]))
    assert g.strand_attributes["root_index"].tolist() == [0, 3]
    meta = g.metadata["usc_hairsalon"]
    assert meta["num_slots"] == 4 and meta["num_empty_slots"] == 2
    assert meta["empty_slots"]["index"] == [1, 2] and meta["empty_slots"]["vertices"] == [1, 0]
    # The writer restores the empty slots: the same bytes come back.
    out = tmp_path / "out.data"
    mane.save(g, out)
    assert out.read_bytes() == raw
    # Without the slot information the strands are written densely.
    usc_hairsalon.write(g, out, restore_empty=False)
    assert out.read_bytes() == usc_bytes([a, b])


@pytest.mark.parametrize("raw,msg", [
    (struct.pack("<i", 0), "no strands"),
    (struct.pack("<i", -5), "negative"),
    (struct.pack("<i", 1 << 30) + b"\0" * 8, "more than the file"),
    (struct.pack("<ii", 1, -2), "negative vertex count"),
    (struct.pack("<ii", 1, 1 << 28) + b"\0" * 24, "truncated"),
    (usc_bytes([np.ones((2, 3))]) + b"\0", "unexpected bytes"),
    (usc_bytes([np.ones((1, 3)), np.zeros((0, 3))]), "empty"),
    (usc_bytes([np.ones((2, 3))])[:-2], "truncated"),
    (b"\1\0", "truncated"),
])
def test_usc_refuses(tmp_path, raw, msg):
    f = tmp_path / "bad.data"
    f.write_bytes(raw)
    with pytest.raises(FormatError, match=msg):
        mane.load(f)


def test_usc_nan_offset(tmp_path):
    s = np.ones((2, 3), np.float32)
    s[1, 1] = np.inf
    f = tmp_path / "n.data"
    f.write_bytes(usc_bytes([s]))
    with pytest.raises(FormatError, match="not finite") as err:
        mane.load(f)
    assert err.value.offset == 8 + 12 + 4


def test_usc_ct2hair_variant(tmp_path):
    rows = np.arange(21, dtype=np.float32).reshape(3, 7)
    f = tmp_path / "v.bin"
    f.write_bytes(struct.pack("<ii", 1, 3) + rows.tobytes())
    g = usc_hairsalon.read(f, floats_per_point=7)
    np.testing.assert_array_equal(g.points, rows[:, :3])


# ----------------------------------------------------------------------------- TressFX
def test_tfx_v4_all_arrays(tmp_path):
    S, N = 3, 4
    rng = np.random.default_rng(2)
    pos = rng.normal(size=(S * N, 4)).astype(np.float32)
    pos[:, 3] = 1.0
    pos[::N, 3] = 0.0  # roots immovable
    pos[1::N, 3] = 0.0  # and the second vertex
    suv, vuv = rng.random((S, 2)), rng.random((S * N, 2))
    th, col = rng.random(S), rng.random((S * N, 4))
    f = tmp_path / "a.tfx"
    f.write_bytes(tfx4_bytes(pos, S, N, suv, vuv, th, col))
    g = load_raw(f)
    assert g.counts.tolist() == [N] * S
    np.testing.assert_array_equal(g.points, pos[:, :3])
    np.testing.assert_array_equal(g.point_attributes["immovable"], pos[:, 3] == 0)
    assert g.point_attributes["immovable"].sum() == 2 * S
    np.testing.assert_array_equal(g.strand_attributes["uv"], suv.astype(np.float32))
    np.testing.assert_array_equal(g.point_attributes["uv"], vuv.astype(np.float32))
    np.testing.assert_array_equal(g.strand_attributes["thickness"], th.astype(np.float32))
    np.testing.assert_array_equal(g.colors, col[:, :3].astype(np.float32))
    np.testing.assert_allclose(g.transparency, 1 - col[:, 3].astype(np.float32), atol=1e-7)
    assert g.metadata["tressfx"]["version"] == 4.0


def test_tfx_v3_immovable_convention(tmp_path):
    S, N = 2, 6
    pos = np.arange(S * N * 3, dtype=np.float32).reshape(-1, 3)
    f = tmp_path / "v3.tfx"
    f.write_bytes(tfx3_bytes(pos, S, N, both_ends=0, thickness=[0.5, 0.7], strand_uv=[[0, 1], [1, 0]]))
    g = load_raw(f)
    np.testing.assert_array_equal(g.points, pos)
    want = np.tile([True, True, False, False, False, False], S)  # the first two of every strand
    np.testing.assert_array_equal(g.point_attributes["immovable"], want)
    np.testing.assert_array_equal(g.strand_attributes["thickness"], np.float32([0.5, 0.7]))
    np.testing.assert_array_equal(g.strand_attributes["uv"], np.float32([[0, 1], [1, 0]]))
    f.write_bytes(tfx3_bytes(pos, S, N, both_ends=1))
    want = np.tile([True, True, False, False, True, True], S)  # and the last two
    np.testing.assert_array_equal(load_raw(f).point_attributes["immovable"], want)
    assert load_raw(f).metadata["tressfx"]["both_ends_immovable"] is True


@pytest.mark.parametrize("mutate,msg", [
    (lambda b: struct.pack("<f", 2.0) + b[4:], "version"),
    (lambda b: b[:100], "160-byte"),
    (lambda b: b[:-1], "truncated"),
    (lambda b: b[:4] + struct.pack("<I", 0) + b[8:], "no strands"),
    (lambda b: b[:4] + struct.pack("<I", 0x7FFFFFFF) + b[8:], "the file has"),
    (lambda b: b[:8] + struct.pack("<I", 1) + b[12:], "numVerticesPerStrand"),
    (lambda b: b[:12] + struct.pack("<I", 0) + b[16:], "no positions"),
    (lambda b: b[:12] + struct.pack("<I", 8) + b[16:], "header"),
    (lambda b: b[:12] + struct.pack("<I", 0xFFFFFF00) + b[16:], "truncated"),
])
def test_tfx_refuses(tmp_path, mutate, msg):
    pos = np.ones((8, 4), np.float32)
    f = tmp_path / "x.tfx"
    f.write_bytes(mutate(tfx4_bytes(pos, 2, 4)))
    with pytest.raises(FormatError, match=msg):
        mane.load(f)


def test_tfx_writer_layout(tmp_path):
    g = sample_groom([4, 4, 4], transparency=False)
    g = g.replace(strand_attributes={"uv": np.float32([[0, 1], [2, 3], [4, 5]])})
    f = tmp_path / "w.tfx"
    mane.save(g, f)
    raw = f.read_bytes()
    version, S, N, o_pos, o_suv, o_vuv, o_th, o_col = struct.unpack_from("<f7I", raw, 0)
    assert (version, S, N, o_pos) == (4.0, 3, 4, 160)
    pos = np.frombuffer(raw, "<f4", 48, o_pos).reshape(12, 4)
    np.testing.assert_array_equal(pos[:, :3], g.points)
    np.testing.assert_array_equal(pos[:, 3] == 0, g.point_attributes["immovable"])
    np.testing.assert_array_equal(np.frombuffer(raw, "<f4", 6, o_suv), np.arange(6))
    assert o_vuv == 0 and o_th == 0
    rgba = np.frombuffer(raw, "<f4", 48, o_col).reshape(12, 4)
    np.testing.assert_array_equal(rgba[:, :3], g.colors)
    assert np.all(rgba[:, 3] == 1)
    mane.save(sample_groom([3, 4]), tmp_path / "u.tfx")   # ragged: resampled to 4 points
    assert load_raw(tmp_path / "u.tfx").uniform_count == 4


def test_tfxproj(tmp_path):
    a = np.arange(2 * 4 * 3, dtype=np.float32).reshape(-1, 3)
    b = np.arange(3 * 4 * 3, dtype=np.float32).reshape(-1, 3) + 1000
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "a.tfx").write_bytes(tfx3_bytes(a, 2, 4))
    (tmp_path / "b.tfx").write_bytes(tfx3_bytes(b, 3, 4, both_ends=1))
    proj = tmp_path / "p.tfxproj"
    proj.write_text(
        "Version 3.0\n# comment\nproject_name Test\n"
        "parts/a.tfx 4 0.4 5.0 a.tfxsim first part\n"
        "b.tfx 2 0.5 3.0 b.tfxsim\n"
        "head.sdkmesh\nlengthConstraintIterations 3\n"
        "collision_sphere 1 2 3 4.5\ncollision_sphere 0 0 0 1\nhairColor 0.5 0.25 0.125\n")
    g = load_raw(proj)
    np.testing.assert_array_equal(g.points, np.concatenate([a, b]))
    assert g.strand_attributes["part"].tolist() == [0, 0, 1, 1, 1]
    p = g.metadata["tressfx_project"]
    assert p["collision_spheres"] == [{"center": [1, 2, 3], "radius": 4.5},
                                      {"center": [0, 0, 0], "radius": 1}]
    assert p["settings"]["lengthConstraintIterations"] == 3
    assert p["settings"]["hairColor"] == [0.5, 0.25, 0.125]
    assert [q["name"] for q in p["parts"]] == ["first part", "b"]
    assert p["parts"][0]["follow_hairs_per_guide"] == 4 and p["meshes"] == ["head.sdkmesh"]
    assert g.point_attributes["immovable"].sum() == 2 * 2 + 3 * 4
    json.dumps(g.metadata)
    proj.write_text("missing.tfx 4 0.4 5.0 x.tfxsim\n")
    with pytest.raises(FormatError, match="not found"):
        load_raw(proj)
    proj.write_text("/etc/a.tfx 4 0.4 5.0 x.tfxsim\n")
    with pytest.raises(FormatError, match="relative"):
        load_raw(proj)
    proj.write_text("collision_sphere 1 2\n")
    with pytest.raises(FormatError, match="line 1"):
        load_raw(proj)
    proj.write_text("# nothing\n")
    with pytest.raises(FormatError, match="no .tfx"):
        load_raw(proj)


# ----------------------------------------------------------------------------- strand PLY
ASCII_PLY = """ply
format ascii 1.0
comment hand written
element vertex 5
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
property float width
element strand 2
property ushort nsegs
end_header
0 0 0 255 0 0 0.5
0 1 0 255 0 0 0.5
0 2 0 255 0 0 0.25
1 0 0 0 51 255 1
1 0 1.5 0 51 255 1
2
1
"""


def test_ply_ascii_reads(tmp_path):
    f = tmp_path / "a.ply"
    f.write_text(ASCII_PLY)
    g = mane.load(f)
    assert g.counts.tolist() == [3, 2]
    np.testing.assert_array_equal(g.points[4], [1, 0, 1.5])
    np.testing.assert_allclose(g.colors[3], [0, 0.2, 1.0], atol=1e-7)
    np.testing.assert_array_equal(g.widths, np.float32([0.5, 0.5, 0.25, 1, 1]))


def test_ply_binary_with_vertex_count_and_edges(tmp_path):
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\n"
            "property double y\nproperty double z\nelement strand 2\nproperty int vertex_count\n"
            "element edge 2\nproperty int vertex1\nproperty int vertex2\nend_header\n").encode()
    pts = np.arange(12, dtype="<f8")
    f = tmp_path / "b.ply"
    f.write_bytes(head + pts.tobytes() + np.int32([2, 2]).tobytes() + np.int32([0, 1, 2, 3]).tobytes())
    g = load_raw(f)
    assert g.counts.tolist() == [2, 2]
    np.testing.assert_array_equal(g.points, pts.reshape(4, 3).astype(np.float32))


@pytest.mark.parametrize("text,msg", [
    (ASCII_PLY.replace("2\n1\n", "2\n2\n"), "add up"),
    (ASCII_PLY.replace("ply\n", "plx\n", 1), "PLY"),
    (ASCII_PLY.replace("format ascii 1.0", "format binary_big_endian 1.0"), "big_endian"),
    (ASCII_PLY.replace("format ascii 1.0", "format ascii 2.0"), "format"),
    (ASCII_PLY.replace("property float width", "property quux width"), "property"),
    (ASCII_PLY.replace("comment hand written", "bogus line"), "unknown keyword"),
    (ASCII_PLY.replace("element vertex 5", "element vertex 500000000"), "truncated"),
    (ASCII_PLY.replace("element strand 2", "element strand 99999999999"), "truncated"),
    (ASCII_PLY.replace("end_header\n", ""), "end_header"),
    (ASCII_PLY.replace("1 0 1.5", "1 0 nan"), "non-finite"),
    (ASCII_PLY.replace("1 0 1.5", "1 0 x1"), "not a number"),
    (ASCII_PLY + "7\n", "unexpected"),
    (ASCII_PLY.replace("property ushort nsegs", "property ushort foo"), "count property"),
    (ASCII_PLY.replace("element strand 2\nproperty ushort nsegs\n", "").replace("2\n1\n", ""), "strand"),
    (ASCII_PLY.replace("element vertex 5", "element vertex 0"), "no hair"),
])
def test_ply_refuses(tmp_path, text, msg):
    f = tmp_path / "bad.ply"
    f.write_text(text)
    with pytest.raises(FormatError, match=msg):
        mane.load(f)


def test_ply_binary_truncated_counts_checked_before_reading(tmp_path):
    f = tmp_path / "t.ply"
    g = sample_groom()
    strand_ply.write(g, f)
    raw = f.read_bytes()
    f.write_bytes(raw.replace(b"element vertex 14", b"element vertex 4000000000", 1))
    with pytest.raises(FormatError, match="truncated"):
        mane.load(f)
    f.write_bytes(raw[:-3])
    with pytest.raises(FormatError, match="truncated"):
        mane.load(f)


def test_ply_writer_is_parseable_by_numpy(tmp_path):
    g = sample_groom()
    f = tmp_path / "w.ply"
    strand_ply.write(g, f)
    raw = f.read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    header = raw[:end].decode()
    assert "format binary_little_endian 1.0" in header and "comment mane bool immovable" in header
    props = [ln.split()[2] for ln in header.splitlines() if ln.startswith("property")]
    vprops = props[:props.index("nsegs")]
    assert vprops[:3] == ["x", "y", "z"]
    types = {"float": "<f4", "uchar": "u1", "ushort": "<u2", "int": "<i4"}
    vtypes = [types[ln.split()[1]] for ln in header.splitlines() if ln.startswith("property")]
    dt = np.dtype(list(zip(vprops, vtypes[:len(vprops)])))
    rows = np.frombuffer(raw, dt, g.num_points, end)
    np.testing.assert_array_equal(np.stack([rows["x"], rows["y"], rows["z"]], 1), g.points)
    np.testing.assert_array_equal(rows["immovable"], g.point_attributes["immovable"].astype(np.uint8))
    # ASCII too: %.9g keeps float32 exact
    strand_ply.write(g, f, binary=False)
    back = mane.load(f)
    assert back.equals(g)
    np.testing.assert_array_equal(back.point_attributes["immovable"], g.point_attributes["immovable"])


# ----------------------------------------------------------------------------- native .npz
def test_npz_keeps_everything(tmp_path):
    g = sample_groom()
    g = g.replace(metadata={"note": "hi", "nested": {"a": [1, 2.5]}},
                  strand_attributes={"uv": np.arange(8, dtype=np.float32).reshape(4, 2)})
    f = tmp_path / "g.npz"
    mane.save(g, f)
    with np.load(f, allow_pickle=False) as z:  # independent check of the members
        assert set(z.files) >= {"points", "counts", "widths", "colors", "transparency",
                                "point:immovable", "strand:uv", "metadata"}
        np.testing.assert_array_equal(z["points"], g.points)
        assert json.loads(str(z["metadata"]))["note"] == "hi"
    back = mane.load(f)
    assert back.equals(g)
    assert back.point_attributes["immovable"].dtype == bool
    np.testing.assert_array_equal(back.strand_attributes["uv"], g.strand_attributes["uv"])
    assert back.metadata["nested"] == {"a": [1, 2.5]}


def _npz(path, **arrays):
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


@pytest.mark.parametrize("arrays,msg", [
    ({"counts": np.int32([2])}, "missing"),
    ({"points": np.zeros((2, 3), np.float32), "counts": np.int32([2]), "evil": np.zeros(1)}, "unknown member"),
    ({"points": np.zeros((2, 2), np.float32), "counts": np.int32([2])}, "shape"),
    ({"points": np.zeros((2, 3), np.float32), "counts": np.int32([3])}, "add up"),
    ({"points": np.full((2, 3), np.nan, np.float32), "counts": np.int32([2])}, "NaN"),
    ({"points": np.zeros((2, 3), np.float32), "counts": np.int32([2]), "metadata": np.array("[1]")},
     "JSON object"),
    ({"points": np.zeros((2, 3), np.float32), "counts": np.int32([2]), "metadata": np.array("{")},
     "JSON"),
    ({"points": np.zeros((2, 3), np.float32), "counts": np.int32([2]),
      "point:x": np.array(["a", "b"])}, "string"),
    ({"points": np.zeros((2, 3), np.float32), "counts": np.float32([2])}, "dtype"),
])
def test_npz_refuses(tmp_path, arrays, msg):
    f = tmp_path / "bad.npz"
    _npz(f, **arrays)
    with pytest.raises(FormatError, match=msg):
        mane.load(f)


def test_npz_refuses_pickles_and_lying_headers(tmp_path):
    f = tmp_path / "obj.npz"
    _npz_obj = np.empty(2, dtype=object)
    _npz_obj[:] = [1, 2]
    with open(f, "wb") as fh:
        np.savez(fh, points=np.zeros((2, 3), np.float32), counts=np.int32([2]), **{"point:x": _npz_obj})
    with pytest.raises(FormatError, match="not allowed"):
        mane.load(f)
    # An .npy header that declares far more data than the member holds.
    import io
    bio = io.BytesIO()
    np.lib.format.write_array_header_1_0(bio, {"descr": "<f4", "fortran_order": False,
                                               "shape": (10 ** 9, 3)})
    with zipfile.ZipFile(f, "w") as zf:
        zf.writestr("points.npy", bio.getvalue() + b"\0" * 24)
        buf = io.BytesIO()
        np.save(buf, np.int32([2]))
        zf.writestr("counts.npy", buf.getvalue())
    with pytest.raises(FormatError, match="declares"):
        mane.load(f)
    f.write_bytes(b"PK\3\4 not really a zip")
    with pytest.raises(FormatError, match="zip"):
        mane.load(f)


# ----------------------------------------------------------------------------- every writer
WRITABLE = [".hair", ".data", ".ply", ".npz", ".tfx", ".usda", ".usdc", ".usd", ".abc"]


@pytest.mark.parametrize("suffix", WRITABLE)
def test_round_trip(tmp_path, suffix):
    """The same groom through every writer: points exact (float32 everywhere)."""
    uniform = suffix == ".tfx"
    g = sample_groom([4, 4, 4] if uniform else [3, 5, 2, 4], seed=7)
    f = tmp_path / f"g{suffix}"
    mane.save(g, f)
    back = mane.load(f)
    np.testing.assert_array_equal(back.counts, g.counts)
    np.testing.assert_array_equal(back.points, g.points)  # exact, all formats store float32
    if suffix in (".hair", ".ply", ".npz", ".usda", ".usdc", ".usd"):
        assert back.equals(g)  # widths, colors, transparency exact too
    if suffix == ".abc":
        np.testing.assert_array_equal(back.widths, g.widths)
    if suffix == ".tfx":  # transparency travels as alpha = 1 - t: one rounding
        np.testing.assert_array_equal(back.colors, g.colors)
        np.testing.assert_allclose(back.transparency, g.transparency, atol=6e-8)
    if suffix in (".ply", ".npz", ".usda", ".tfx"):
        np.testing.assert_array_equal(back.point_attributes["immovable"], g.point_attributes["immovable"])


def test_round_trip_without_optional_arrays(tmp_path):
    g = sample_groom(widths=False, colors=False, transparency=False, attrs=False)
    for suffix in (".ply", ".npz", ".usda", ".abc", ".data"):
        back = mane.load(mane.save(g, tmp_path / f"bare{suffix}"))
        assert back.equals(g), suffix


@pytest.mark.parametrize("suffix", WRITABLE)
def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch, suffix):
    """A write that fails midway leaves the previous file byte for byte."""
    uniform = suffix == ".tfx"
    g = sample_groom([4, 4] if uniform else [3, 4])
    f = tmp_path / f"keep{suffix}"
    mane.save(g, f)
    before = f.read_bytes()

    import os

    real_replace = os.replace

    class Boom(RuntimeError):
        pass

    def failing_replace(src, dst, *a, **k):  # the data was written; the commit step fails
        raise Boom("disk full")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(Boom):
        mane.save(sample_groom([4, 4] if uniform else [2, 2], seed=3), f)
    monkeypatch.setattr(os, "replace", real_replace)
    assert f.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [f.name]  # no temporary left behind


def test_failed_write_midway_through_data(tmp_path, monkeypatch):
    g = sample_groom()
    f = tmp_path / "mid.hair"
    mane.save(g, f)
    before = f.read_bytes()
    import mane.io.cyhair as mod

    class Fail(Exception):
        pass

    real_write = mod.atomic_write_path

    from contextlib import contextmanager

    @contextmanager
    def half_then_fail(path):
        with real_write(path) as tmp:
            yield tmp
            assert tmp.stat().st_size > 0  # something was written to the temporary
            raise Fail()

    monkeypatch.setattr(mod, "atomic_write_path", half_then_fail)
    with pytest.raises(Fail):
        mane.save(sample_groom(seed=5), f)
    assert f.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["mid.hair"]


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(UnsupportedFormatError):
        mane.load(tmp_path / "x.xyz")
    with pytest.raises(FormatError, match="no such file"):
        mane.load(tmp_path / "x.hair")
    (tmp_path / "folder.tfx").mkdir()
    with pytest.raises(FormatError, match="folder.tfx: a folder, not a file"):
        mane.load(tmp_path / "folder.tfx")
    (tmp_path / "head.obj").mkdir()
    with pytest.raises(FormatError, match="head.obj: a folder, not a file"):
        mane.load_mesh(tmp_path / "head.obj")
    with pytest.raises(UnsupportedFormatError):
        mane.save(sample_groom(), tmp_path / "x.tfxproj")
    (tmp_path / "dir.hair").mkdir()
    with pytest.raises(ManeError):
        mane.load(tmp_path / "dir.hair")
