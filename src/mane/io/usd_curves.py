"""USD ``BasisCurves`` (``.usd``, ``.usda``, ``.usdc``) through ``usd-core`` (``pxr``).

A ``UsdGeom.BasisCurves`` prim holds ``points``, ``curveVertexCounts``, ``widths`` (with an
interpolation), ``type`` (linear / cubic), ``basis`` and ``wrap``. Time samples on ``points``
carry animation, which is how a simulated groom goes to other tools.

Writing (:func:`write`): one prim ``/Hair`` (the default prim), type ``linear``, wrap
``nonperiodic``, stage metadata ``metersPerUnit = 1`` and ``upAxis = "Y"``. ``widths`` are
vertex-interpolated; ``colors`` go to ``primvars:displayColor`` (vertex) and transparency to
``primvars:displayOpacity = 1 - transparency``, with the exact value also in
``primvars:mane:transparency``; 1-D/2-D numeric point and strand attributes go to
``primvars:mane:NAME`` (vertex / uniform). ``write(groom, path, frames=[...], fps=24)``
writes every (P, 3) array of ``frames`` as a time sample of ``points`` at time codes
0, 1, 2, ... (the groom's own points stay the default value), with ``timeCodesPerSecond`` and
``framesPerSecond`` set to ``fps``.

Reading (:func:`read`): every BasisCurves prim of the stage, in world space (their
transforms applied), concatenated (strand attribute ``prim``: which prim a strand came from).
``time`` picks a time code; by default the authored default value, else the first time
sample. ``metadata['usd']['num_time_samples']`` reports the animation length. A stage whose
upAxis is Z is rotated to Y-up; points and widths are scaled by an *authored*
``metersPerUnit`` (an unauthored one is left alone rather than taking USD's fallback of
centimetres). usd-core can crash or try to allocate absurd amounts on a corrupt crate file,
so reading runs in a child process (:func:`mane.io.binary.read_in_child`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError, ManeError, UsageError
from ..groom import Groom, up_axis_matrix
from .atomic import atomic_write_path
from .binary import read_in_child
from .curves import build_groom, check_counts, check_time, concat, drop_short_curves, object_index, to_world

PRIM_PATH = "/Hair"
_MAGIC = {b"PXR-USDC": "usdc", b"#usda 1.": "usda"}


def _sniff(path: Path) -> None:
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        raise FormatError(f"cannot read the file ({exc.strerror or exc})", path) from None
    if head not in _MAGIC:
        raise FormatError(f"not a USD file: it starts with {head!r} (expected 'PXR-USDC' or '#usda 1.')",
                          path, 0)
    if path.suffix.lower() == ".usdc" and head != b"PXR-USDC":
        raise FormatError("a .usdc file must be a binary crate file", path, 0)
    if path.suffix.lower() == ".usda" and head != b"#usda 1.":
        raise FormatError("a .usda file must be text starting with '#usda 1.0'", path, 0)


def read(path, time: float | None = None, isolate: bool = True, timeout: float = 300.0) -> Groom:
    path = Path(path)
    time = check_time(time, "(a USD time code)")
    _sniff(path)
    if isolate:
        return read_in_child("usd_curves", path, {"time": time}, timeout=timeout)
    return read_in_process(path, time=time)


def _interp(values: np.ndarray, interpolation: str, counts: np.ndarray, what: str, where: str, path):
    """Per-point values from a primvar of any interpolation (None when it does not fit)."""
    P, S = int(counts.sum()), len(counts)
    n = len(values)
    if n == 0:
        return None
    if interpolation in ("vertex", "varying") and n == P:
        return values
    if interpolation == "uniform" and n == S:
        return np.repeat(values, counts, axis=0)
    if interpolation == "constant" and n >= 1:
        return np.repeat(values[:1], P, axis=0)
    if n == P:
        return values
    raise FormatError(f"{where}: {n} {what} values do not fit {interpolation} interpolation "
                      f"({P} points, {S} curves)", path)


def _require_pxr() -> None:
    """Raise ManeError unless OpenUSD's Python bindings (pxr, from usd-core) import."""
    try:
        import pxr  # noqa: F401
    except ImportError as exc:
        raise ManeError(f"USD files need OpenUSD's Python bindings ({exc}); pip install usd-core "
                        "(a mane dependency)") from None


def read_in_process(path, time: float | None = None) -> Groom:
    _require_pxr()
    from pxr import Sdf, Tf, Usd, UsdGeom

    path = Path(path)
    try:
        layer = Sdf.Layer.FindOrOpen(str(path))
        if layer is None:
            raise FormatError("usd-core cannot open the file", path)
        layer.Reload()
        stage = Usd.Stage.Open(layer, Usd.Stage.LoadAll)
    except FormatError:
        raise
    except Tf.ErrorException as exc:
        raise FormatError(f"usd-core cannot open the file ({str(exc).strip()[:300]})", path) from None
    if stage is None:
        raise FormatError("usd-core cannot open the file", path)
    up = str(UsdGeom.GetStageUpAxis(stage)).lower()
    mpu_authored = bool(UsdGeom.StageHasAuthoredMetersPerUnit(stage))
    mpu = float(UsdGeom.GetStageMetersPerUnit(stage)) if mpu_authored else 1.0
    if not np.isfinite(mpu) or mpu <= 0:
        raise FormatError(f"metersPerUnit must be a positive number, got {mpu}", path)
    parts = []
    max_samples = 0
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.BasisCurves):
            continue
        curves = UsdGeom.BasisCurves(prim)
        pattr = curves.GetPointsAttr()
        nsamples = int(pattr.GetNumTimeSamples())
        max_samples = max(max_samples, nsamples)
        if time is not None:
            tc = Usd.TimeCode(time)
        elif pattr.Get(Usd.TimeCode.Default()) is not None:
            tc = Usd.TimeCode.Default()
        elif nsamples:
            tc = Usd.TimeCode(pattr.GetTimeSamples()[0])
        else:
            tc = Usd.TimeCode.Default()
        pts = pattr.Get(tc)
        cnt = curves.GetCurveVertexCountsAttr().Get(tc)
        if pts is None or cnt is None or len(pts) == 0:
            continue
        where = str(prim.GetPath())
        pts = np.array(pts, dtype=np.float64).reshape(-1, 3)
        counts = np.array(cnt, dtype=np.int64).reshape(-1)
        check_counts(pts, counts, where, path, "curveVertexCounts add up to {total} but there are {points} points")
        pv_api = UsdGeom.PrimvarsAPI(prim)
        widths = None
        w = curves.GetWidthsAttr().Get(tc)
        if w is not None and len(w):
            widths = _interp(np.array(w, dtype=np.float64).reshape(-1), curves.GetWidthsInterpolation(),
                             counts, "width", where, path)
        colors = transparency = None
        dc = pv_api.GetPrimvar("displayColor")
        if dc and dc.HasAuthoredValue():
            v = dc.ComputeFlattened(tc)
            if v is not None and len(v):
                colors = _interp(np.array(v, dtype=np.float64).reshape(-1, 3), dc.GetInterpolation(),
                                 counts, "displayColor", where, path)
        exact_t = pv_api.GetPrimvar("mane:transparency")
        op = pv_api.GetPrimvar("displayOpacity")
        if exact_t and exact_t.HasAuthoredValue():
            v = exact_t.ComputeFlattened(tc)
            if v is not None and len(v):
                transparency = _interp(np.array(v, dtype=np.float64).reshape(-1),
                                       exact_t.GetInterpolation(), counts, "transparency", where, path)
        elif op and op.HasAuthoredValue():
            v = op.ComputeFlattened(tc)
            if v is not None and len(v):
                transparency = 1.0 - _interp(np.array(v, dtype=np.float64).reshape(-1),
                                             op.GetInterpolation(), counts, "displayOpacity", where, path)
        point_attrs, strand_attrs = {}, {}
        for pv in pv_api.GetPrimvars():
            name = str(pv.GetPrimvarName())
            if not name.startswith("mane:") or name == "mane:transparency":
                continue
            v = pv.ComputeFlattened(tc)
            if v is None:
                continue
            arr = np.array(v)
            if arr.dtype.kind not in "biuf" or arr.ndim not in (1, 2):
                continue
            interp = pv.GetInterpolation()
            key = name[len("mane:"):]
            if interp == "uniform" and len(arr) == len(counts):
                strand_attrs[key] = arr
            elif interp in ("vertex", "varying") and len(arr) == len(pts):
                point_attrs[key] = arr
        xf = UsdGeom.Xformable(prim)
        world = np.array(xf.ComputeLocalToWorldTransform(tc), dtype=np.float64).reshape(4, 4).T
        if not np.all(np.isfinite(world)):
            raise FormatError(f"{where}: its transform is not finite", path)
        pts, widths = to_world(pts, widths, world)
        parts.append(dict(where=where, points=pts, counts=counts, widths=widths, colors=colors,
                          transparency=transparency, point_attrs=point_attrs,
                          strand_attrs=strand_attrs, type=str(curves.GetTypeAttr().Get()),
                          wrap=str(curves.GetWrapAttr().Get()), samples=nsamples))
    if not parts:
        raise FormatError("the stage has no BasisCurves prim with points", path)

    def cat(key):
        return concat([p[key] for p in parts])

    points, counts = cat("points"), cat("counts")
    widths, colors, transparency = cat("widths"), cat("colors"), cat("transparency")
    prim_index = object_index([p["counts"] for p in parts])

    def common(key):
        names = set.intersection(*(set(p[key]) for p in parts))
        out = {}
        for n in sorted(names):
            arrs = [p[key][n] for p in parts]
            if len({(a.dtype.kind, a.shape[1:]) for a in arrs}) == 1:
                out[n] = np.concatenate(arrs)
        return out

    point_attrs, strand_attrs = common("point_attrs"), common("strand_attrs")
    strand_attrs.setdefault("prim", prim_index)
    m = np.eye(4)
    if up == "z":
        m = up_axis_matrix("z", "y")
    m = np.diag([mpu, mpu, mpu, 1.0]) @ m
    points = points @ m[:3, :3].T
    if widths is not None:
        widths = widths * mpu
    for name, arr in (("points", points), ("widths", widths), ("colors", colors),
                      ("transparency", transparency)):
        if arr is not None and (not np.all(np.isfinite(arr)) or np.abs(arr).max() > np.finfo(np.float32).max):
            raise FormatError(f"{name} contain NaN, infinite or out-of-range values", path)
    counts, per_point, strand_attrs, dropped = drop_short_curves(
        counts, path, dict(points=points, widths=widths, colors=colors, transparency=transparency,
                           point_attributes=point_attrs), strand_attrs)
    meta = {"format": "USD",
            "usd": {"prims": [p["where"] for p in parts], "types": [p["type"] for p in parts],
                    "wraps": [p["wrap"] for p in parts], "num_time_samples": max_samples,
                    "time": time, "stage_up_axis": up.upper(),
                    "meters_per_unit": mpu if mpu_authored else None,
                    "start_time_code": float(stage.GetStartTimeCode()),
                    "end_time_code": float(stage.GetEndTimeCode()),
                    "time_codes_per_second": float(stage.GetTimeCodesPerSecond()),
                    "dropped_short_curves": dropped},
            "up_axis": "y", "units": "metres" if mpu_authored else "as stored",
            # converted above from what the stage declares: metres (when authored) and Y-up
            "file_frame": {"units": "m" if mpu_authored else None,
                           "units_source": "declared" if mpu_authored else None,
                           "up": "y", "up_source": "declared"}}
    return build_groom(path, per_point.pop("points"), counts, **per_point, strand_attributes=strand_attrs,
                       metadata=meta)


_VT = {("f", 1): "FloatArray", ("f", 2): "Vec2fArray", ("f", 3): "Vec3fArray",
       ("i", 1): "IntArray", ("u", 1): "IntArray", ("b", 1): "BoolArray"}
_SDF = {"FloatArray": "FloatArray", "Vec2fArray": "Float2Array", "Vec3fArray": "Float3Array",
        "IntArray": "IntArray", "BoolArray": "BoolArray"}


def write(groom: Groom, path, frames=None, fps: float = 24.0) -> None:
    """Write a BasisCurves stage (see the module docstring); ``frames`` animate ``points``."""
    _require_pxr()
    from pxr import Sdf, Usd, UsdGeom, Vt

    fps = float(fps)
    if not np.isfinite(fps) or fps <= 0:
        raise UsageError(f"fps must be a positive number, got {fps}")
    frame_arrays = []
    if frames is not None:
        for i, f in enumerate(frames):
            a = np.asarray(f, dtype=np.float32)
            if a.shape != groom.points.shape:
                raise UsageError(f"frame {i} has shape {a.shape}; expected {groom.points.shape}")
            if not np.all(np.isfinite(a)):
                raise UsageError(f"frame {i} has NaN or infinite positions")
            frame_arrays.append(np.ascontiguousarray(a))
    with atomic_write_path(path) as tmp:
        layer = Sdf.Layer.CreateNew(str(tmp))
        if layer is None:
            raise FormatError("usd-core cannot create the file", tmp)
        stage = Usd.Stage.Open(layer)
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        curves = UsdGeom.BasisCurves.Define(stage, PRIM_PATH)
        stage.SetDefaultPrim(curves.GetPrim())
        curves.CreateTypeAttr(UsdGeom.Tokens.linear)
        curves.CreateWrapAttr(UsdGeom.Tokens.nonperiodic)
        pattr = curves.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(groom.points))
        curves.CreateCurveVertexCountsAttr(Vt.IntArray.FromNumpy(groom.counts.astype(np.int32)))
        lo, hi = groom.bbox()
        curves.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([lo, hi]).astype(np.float32)))
        if groom.widths is not None:
            curves.CreateWidthsAttr(Vt.FloatArray.FromNumpy(groom.widths))
            curves.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
        pv_api = UsdGeom.PrimvarsAPI(curves.GetPrim())
        if groom.colors is not None:
            pv = curves.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex)
            pv.Set(Vt.Vec3fArray.FromNumpy(groom.colors))
        if groom.transparency is not None:
            op = curves.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.vertex)
            op.Set(Vt.FloatArray.FromNumpy((1.0 - groom.transparency).astype(np.float32)))
            ex = pv_api.CreatePrimvar("mane:transparency", Sdf.ValueTypeNames.FloatArray,
                                      UsdGeom.Tokens.vertex)
            ex.Set(Vt.FloatArray.FromNumpy(groom.transparency))
        for attrs, interp in ((groom.point_attributes, UsdGeom.Tokens.vertex),
                              (groom.strand_attributes, UsdGeom.Tokens.uniform)):
            for name, arr in attrs.items():
                arr = np.asarray(arr)
                width = 1 if arr.ndim == 1 else (arr.shape[1] if arr.ndim == 2 else 0)
                vt_name = _VT.get((arr.dtype.kind, width))
                if vt_name is None or not Sdf.Path.IsValidNamespacedIdentifier(f"mane:{name}"):
                    continue
                if arr.dtype.kind == "f":
                    arr = arr.astype(np.float32)
                elif arr.dtype.kind in "iu":
                    arr = arr.astype(np.int32)
                pv = pv_api.CreatePrimvar(f"mane:{name}", getattr(Sdf.ValueTypeNames, _SDF[vt_name]),
                                          interp)
                pv.Set(getattr(Vt, vt_name).FromNumpy(np.ascontiguousarray(arr)))
        if frame_arrays:
            stage.SetStartTimeCode(0)
            stage.SetEndTimeCode(len(frame_arrays) - 1)
            stage.SetTimeCodesPerSecond(fps)
            stage.SetFramesPerSecond(fps)
            for i, a in enumerate(frame_arrays):
                pattr.Set(Vt.Vec3fArray.FromNumpy(a), Usd.TimeCode(i))
        layer.Save()
        del stage, layer
