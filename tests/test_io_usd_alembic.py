"""USD BasisCurves and Alembic curves: files made with pxr / alembic3d here, golden values by NumPy."""
from __future__ import annotations

import numpy as np
import pytest

import mane
from mane import FormatError, UsageError
from mane.io import alembic_curves, usd_curves
from mane.io.binary import read_in_child
from test_io_helpers import sample_groom

pxr = pytest.importorskip("pxr")
alembic3d = pytest.importorskip("alembic3d")


# ----------------------------------------------------------------------------- USD
def test_usd_writer_stage_metadata_and_animation(tmp_path):
    from pxr import Usd, UsdGeom

    g = sample_groom([3, 4], seed=4)
    frames = [g.points + np.float32(i) for i in range(1, 4)]
    f = tmp_path / "anim.usda"
    usd_curves.write(g, f, frames=frames, fps=30.0)
    stage = Usd.Stage.Open(str(f))
    assert UsdGeom.GetStageUpAxis(stage) == "Y"
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetTimeCodesPerSecond() == 30.0
    curves = UsdGeom.BasisCurves(stage.GetPrimAtPath("/Hair"))
    assert curves.GetTypeAttr().Get() == "linear" and curves.GetWrapAttr().Get() == "nonperiodic"
    pattr = curves.GetPointsAttr()
    assert list(pattr.GetTimeSamples()) == [0.0, 1.0, 2.0]
    np.testing.assert_array_equal(np.array(pattr.Get(Usd.TimeCode(1))), frames[1])
    assert list(curves.GetCurveVertexCountsAttr().Get()) == [3, 4]

    rest = mane.load(f)  # the default value: the groom's own points
    np.testing.assert_array_equal(rest.points, g.points)
    assert rest.metadata["usd"]["num_time_samples"] == 3
    at2 = usd_curves.read(f, time=2)
    np.testing.assert_array_equal(at2.points, frames[2])


def test_usd_time_default_is_first_sample_when_no_default(tmp_path):
    from pxr import Usd, UsdGeom, Vt

    f = tmp_path / "ts.usda"
    stage = Usd.Stage.CreateNew(str(f))
    c = UsdGeom.BasisCurves.Define(stage, "/c")
    c.CreateCurveVertexCountsAttr(Vt.IntArray([2]))
    p = c.CreatePointsAttr()
    p.Set(Vt.Vec3fArray.FromNumpy(np.float32([[0, 0, 0], [0, 1, 0]])), Usd.TimeCode(5))
    p.Set(Vt.Vec3fArray.FromNumpy(np.float32([[0, 0, 0], [0, 2, 0]])), Usd.TimeCode(7))
    stage.GetRootLayer().Save()
    g = mane.load(f)
    np.testing.assert_array_equal(g.points, [[0, 0, 0], [0, 1, 0]])
    assert g.metadata["usd"]["num_time_samples"] == 2
    np.testing.assert_array_equal(usd_curves.read(f, time=7).points[1], [0, 2, 0])


def test_usd_z_up_centimetres_and_transforms(tmp_path):
    from pxr import Gf, Usd, UsdGeom, Vt

    f = tmp_path / "z.usda"
    stage = Usd.Stage.CreateNew(str(f))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    xf = UsdGeom.Xform.Define(stage, "/root")
    xf.AddTranslateOp().Set(Gf.Vec3d(10, 20, 30))
    xf.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    c = UsdGeom.BasisCurves.Define(stage, "/root/hair")
    local = np.float32([[0, 0, 0], [0, 0, 1], [1, 0, 0], [1, 1, 0], [1, 2, 0]])
    c.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(local))
    c.CreateCurveVertexCountsAttr(Vt.IntArray([2, 3]))
    c.CreateWidthsAttr(Vt.FloatArray([0.5, 0.25]))
    c.SetWidthsInterpolation(UsdGeom.Tokens.uniform)
    c.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set(Vt.Vec3fArray([Gf.Vec3f(1, 0.5, 0)]))
    stage.GetRootLayer().Save()
    g = mane.load(f)
    world = local.astype(np.float64) * 2 + [10, 20, 30]          # the prim's transform
    z_to_y = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float)   # rotation taking +z to +y
    want = (world @ z_to_y.T) * 0.01                               # then centimetres to metres
    np.testing.assert_allclose(g.points, want, rtol=1e-6, atol=1e-7)
    assert np.allclose(z_to_y @ [0, 0, 1], [0, 1, 0])
    np.testing.assert_allclose(g.widths, np.float32([0.5, 0.5, 0.25, 0.25, 0.25]) * 2 * 0.01, rtol=1e-6)
    np.testing.assert_array_equal(g.colors, np.tile(np.float32([1, 0.5, 0]), (5, 1)))
    assert g.metadata["usd"]["stage_up_axis"] == "Z" and g.metadata["usd"]["meters_per_unit"] == 0.01


def test_usd_several_prims_concatenate(tmp_path):
    from pxr import Usd, UsdGeom, Vt

    f = tmp_path / "two.usda"
    stage = Usd.Stage.CreateNew(str(f))
    for i, name in enumerate(("/a", "/b")):
        c = UsdGeom.BasisCurves.Define(stage, name)
        c.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.float32([[i, 0, 0], [i, 1, 0]])))
        c.CreateCurveVertexCountsAttr(Vt.IntArray([2]))
    stage.GetRootLayer().Save()
    g = mane.load(f)
    assert g.num_strands == 2 and g.strand_attributes["prim"].tolist() == [0, 1]
    assert g.metadata["usd"]["prims"] == ["/a", "/b"]


@pytest.mark.parametrize("text,msg", [
    ("#usda 1.0\ndef Xform \"x\" {}\n", "no BasisCurves"),
    ("#usda 1.0\ndef BasisCurves \"c\"\n{\n int[] curveVertexCounts = [3]\n"
     " point3f[] points = [(0,0,0),(1,1,1)]\n}\n", "add up"),
    ("#usda 1.0\ndef BasisCurves \"c\"\n{\n int[] curveVertexCounts = [2]\n"
     " point3f[] points = [(0,0,0),(inf,1,1)]\n}\n", "."),
    ("#usda 1.0\n{{{{ broken", "."),
    ("not usd at all", "not a USD"),
])
def test_usd_refuses(tmp_path, text, msg):
    f = tmp_path / "bad.usda"
    f.write_text(text)
    with pytest.raises(FormatError, match=msg):
        mane.load(f)


def test_usd_bad_frames(tmp_path):
    g = sample_groom([2, 2])
    with pytest.raises(UsageError, match="shape"):
        usd_curves.write(g, tmp_path / "f.usda", frames=[np.zeros((3, 3))])
    with pytest.raises(UsageError, match="NaN"):
        usd_curves.write(g, tmp_path / "f.usda", frames=[np.full((4, 3), np.nan)])
    assert not (tmp_path / "f.usda").exists()


def test_usd_in_process_read_matches_child(tmp_path):
    g = sample_groom(seed=9)
    f = tmp_path / "p.usdc"
    mane.save(g, f)
    assert usd_curves.read(f, isolate=False).equals(usd_curves.read(f))


# ----------------------------------------------------------------------------- Alembic
def _write_abc(path, objects):
    """objects: list of (xform translation or None, points, counts, widths or None, scope)."""
    import imath
    from alembic3d import Abc, AbcGeom

    archive = Abc.OArchive(str(path))
    top = archive.getTop()
    keep = []
    for i, (t, pts, counts, widths, scope) in enumerate(objects):
        parent = top
        if t is not None:
            x = AbcGeom.OXform(top, f"xf{i}")
            s = AbcGeom.XformSample()
            s.setTranslation(imath.V3d(*t))
            x.getSchema().set(s)
            inner = AbcGeom.OXform(x, "inner")
            s2 = AbcGeom.XformSample()
            s2.setScale(imath.V3d(2, 2, 2))
            inner.getSchema().set(s2)
            keep += [x, inner]
            parent = inner
        c = AbcGeom.OCurves(parent, f"curves{i}")
        P = imath.V3fArrayFromBuffer(np.ascontiguousarray(pts, np.float32))
        N = imath.IntArrayFromBuffer(np.ascontiguousarray(counts, np.int32))
        if widths is not None:
            W = imath.FloatArrayFromBuffer(np.ascontiguousarray(widths, np.float32))
            ws = AbcGeom.OFloatGeomParamSample(W, scope)
            sample = AbcGeom.OCurvesSchemaSample(P, N, AbcGeom.CurveType.kLinear,
                                                 AbcGeom.CurvePeriodicity.kNonPeriodic, ws)
        else:
            sample = AbcGeom.OCurvesSchemaSample(P, N)
        c.getSchema().set(sample)
        keep.append(c)
    del keep, top, archive


def test_alembic_hierarchy_and_transforms(tmp_path):
    from alembic3d import AbcGeom

    a = np.float32([[0, 0, 0], [0, 1, 0], [0, 2, 0]])
    b = np.float32([[1, 0, 0], [1, 0, 1], [2, 0, 0], [2, 0, 1]])
    f = tmp_path / "h.abc"
    _write_abc(f, [(None, a, [3], [0.1, 0.2, 0.3], AbcGeom.GeometryScope.kVertexScope),
                   ((5, 6, 7), b, [2, 2], [0.5, 0.25], AbcGeom.GeometryScope.kUniformScope)])
    g = mane.load(f)
    assert g.counts.tolist() == [3, 2, 2]
    want_b = b.astype(np.float64) * 2 + [5, 6, 7]  # child scale 2 under parent translation
    np.testing.assert_allclose(g.points, np.concatenate([a, want_b]), rtol=1e-6)
    np.testing.assert_allclose(g.widths, [0.1, 0.2, 0.3, 1.0, 1.0, 0.5, 0.5], rtol=1e-6)
    assert g.strand_attributes["object"].tolist() == [0, 1, 1]
    assert g.metadata["alembic"]["objects"] == ["/curves0", "/xf1/inner/curves1"]
    assert g.metadata["alembic"]["num_samples"] == 1


def test_alembic_cubic_and_no_widths(tmp_path):
    f = tmp_path / "c.abc"
    pts = np.arange(12, dtype=np.float32).reshape(4, 3)
    _write_abc(f, [(None, pts, [4], None, None)])
    g = mane.load(f)
    np.testing.assert_array_equal(g.points, pts)
    assert g.widths is None and g.metadata["alembic"]["curve_types"] == ["kCubic"]


def test_alembic_writer_round_trip_in_process(tmp_path):
    g = sample_groom()
    f = tmp_path / "w.abc"
    mane.save(g, f)
    back = alembic_curves.read(f, isolate=False)
    np.testing.assert_array_equal(back.points, g.points)
    np.testing.assert_array_equal(back.widths, g.widths)
    assert alembic_curves.check_ogawa(f) > 3


@pytest.mark.parametrize("mutate,msg", [
    (lambda b: b"\x89HDF\r\n\x1a\n" + b[8:], "HDF5"),
    (lambda b: b"NotOgawa" + b[8:], "not an Alembic"),
    (lambda b: b[:10], "truncated"),
    (lambda b: b[:5] + b"\x00" + b[6:], "frozen"),
    (lambda b: b[:8] + (len(b) + 100).to_bytes(8, "little") + b[16:], "outside the file"),
    (lambda b: b[: len(b) // 2], "."),
])
def test_alembic_refuses(tmp_path, mutate, msg):
    g = sample_groom()
    f = tmp_path / "g.abc"
    mane.save(g, f)
    f.write_bytes(mutate(f.read_bytes()))
    with pytest.raises(FormatError, match=msg):
        mane.load(f)


def test_alembic_without_curves(tmp_path):
    from alembic3d import Abc, AbcGeom

    f = tmp_path / "empty.abc"
    archive = Abc.OArchive(str(f))
    AbcGeom.OXform(archive.getTop(), "lonely")
    del archive
    with pytest.raises(FormatError, match="no curves"):
        mane.load(f)


# ----------------------------------------------------------------------------- isolation
def test_child_process_failures_become_format_errors(tmp_path):
    g = sample_groom()
    f = tmp_path / "g.usda"
    mane.save(g, f)
    with pytest.raises(FormatError, match="longer than"):
        read_in_child("usd_curves", f, {"time": None}, timeout=0.001)
    with pytest.raises(FormatError):
        read_in_child("usd_curves", f, {"time": None}, memory_limit=32 << 20)
    with pytest.raises(FormatError, match="AttributeError"):
        read_in_child("binary", f, {})
