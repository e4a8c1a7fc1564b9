"""Alembic ``.abc`` curves: every ``ICurves`` object of an Ogawa archive, in world space.

An Alembic archive is a tree of objects; hair lives in ``ICurves`` objects (linear or cubic,
non-periodic) whose schema holds ``P`` (points), ``nVertices`` (points per curve) and an
optional ``width`` geometry parameter (vertex, varying, uniform or constant scope).
Transforms live in ``IXform`` objects above them. mane walks the whole hierarchy,
multiplies the transforms down to every curves object and concatenates all of them into
one groom (strand attribute ``object``: which curves object a strand came from; the object
paths are in ``metadata['alembic']['objects']``). Control points of cubic curves are taken as
the strand's points (``metadata['alembic']['curve_types']`` says which were cubic).

Reading goes through the PyPI wheel ``alembic3d`` (PyPI's ``alembic`` is an unrelated
database tool). Its C++ reader crashes on some corrupt files, so mane first checks the
Ogawa container structure itself (16-byte header ``"Ogawa" 0xff 0x00 0x01`` + uint64 root
group position; groups are ``uint64 n`` + n uint64 child positions, the high bit marking data;
data is ``uint64 size`` + bytes: every position and size is checked against the file size)
and then reads in a child process (:func:`mane.io.binary.read_in_child`). HDF5 archives are
not supported. ``read(path, time=None)``: ``time`` in seconds picks the sample (default: the
first); the number of samples is in the metadata. Units and axes are kept as stored (Alembic
has none; most DCCs write Y-up).

:func:`write` writes one linear, non-periodic ``OCurves`` object ``/hair`` with widths (vertex
scope), colours (the arbitrary geometry parameter ``Cs``, colour3f per vertex) and transparency
(``mane_transparency``, float per vertex) when the groom has them, and the user properties
``mane_units = "m"`` and ``mane_up = "y"``, which :func:`read` takes as a declaration (other
archives: Y-up by convention, the unit guessed). :func:`read` reads ``Cs`` and
``mane_transparency`` of any scope.
"""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from ..errors import FormatError
from ..groom import Groom
from .atomic import atomic_write_path
from .binary import read_in_child
from .curves import build_groom, check_counts, check_time, concat, drop_short_curves, object_index, to_world

OGAWA_MAGIC = b"Ogawa"
_DATA_BIT = 1 << 63
MAX_DEPTH = 256
MAX_NODES = 1 << 22


def check_ogawa(path) -> int:
    """Check the Ogawa container (header, every group and data block in bounds, no cycles).

    Returns the number of nodes. Reads only the structure, in small pieces.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        fh = open(path, "rb")
    except OSError as exc:
        raise FormatError(f"cannot read the file ({exc.strerror or exc})", path) from None
    with fh:
        head = fh.read(16)
        if head[:5] != OGAWA_MAGIC:
            if head[:4] == b"\x89HDF":
                raise FormatError("an HDF5 Alembic archive; only Ogawa archives are supported", path, 0)
            raise FormatError(f"not an Alembic (Ogawa) archive: it starts with {head[:8]!r}", path, 0)
        if len(head) < 16:
            raise FormatError("truncated: the 16-byte Ogawa header is incomplete", path, len(head))
        if head[5] != 0xFF:
            raise FormatError("the archive was not finished (its frozen flag is not set)", path, 5)
        if head[6:8] != b"\x00\x01":
            raise FormatError(f"unsupported Ogawa version {head[6:8].hex()}", path, 6)
        root = struct.unpack("<Q", head[8:16])[0]

        def read_u64(pos: int, what: str) -> int:
            if pos < 16 or pos + 8 > size:
                raise FormatError(f"{what} at byte {pos} is outside the file ({size} bytes)", path, pos)
            fh.seek(pos)
            return struct.unpack("<Q", fh.read(8))[0]

        seen: set[int] = set()
        stack = [(root, 0, False)]
        nodes = 0
        while stack:
            pos, depth, is_data = stack.pop()
            if pos == 0:
                continue  # an empty group or data block
            nodes += 1
            if depth > MAX_DEPTH or nodes > MAX_NODES:
                raise FormatError("the archive nests too deeply or has too many nodes", path, pos)
            if is_data:
                n = read_u64(pos, "a data block")
                if n > size - pos - 8:
                    raise FormatError(f"a data block declares {n} bytes, past the end of the file",
                                      path, pos)
                continue
            if pos in seen:
                raise FormatError("the archive's groups form a cycle", path, pos)
            seen.add(pos)
            n = read_u64(pos, "a group")
            if n > (size - pos - 8) // 8:
                raise FormatError(f"a group declares {n} children, past the end of the file", path, pos)
            fh.seek(pos + 8)
            children = np.frombuffer(fh.read(8 * n), dtype="<u8")
            for child in children.tolist():
                stack.append((child & ~_DATA_BIT, depth + 1, bool(child & _DATA_BIT)))
    return nodes


def read(path, time: float | None = None, isolate: bool = True, timeout: float = 300.0) -> Groom:
    """Read every curves object of an Alembic archive (see the module docstring)."""
    path = Path(path)
    time = check_time(time, "of seconds")
    check_ogawa(path)
    if isolate:
        return read_in_child("alembic_curves", path, {"time": time}, timeout=timeout)
    return read_in_process(path, time=time)


def _imath_matrix(m) -> np.ndarray:
    """An Imath M44d (row vectors: p' = p M) as a column-vector 4x4 NumPy matrix."""
    return np.array(m, dtype=np.float64).reshape(4, 4).T


def read_in_process(path, time: float | None = None) -> Groom:
    from alembic3d import Abc, AbcGeom

    path = Path(path)
    try:
        archive = Abc.IArchive(str(path))
        top = archive.getTop()
    except Exception as exc:  # noqa: BLE001 - the library's own exceptions
        raise FormatError(f"alembic3d cannot open the archive ({str(exc)[:200]})", path) from None
    selector = Abc.ISampleSelector(0) if time is None else Abc.ISampleSelector(float(time))
    wrap = Abc.WrapExistingFlag.kWrapExisting
    found = []  # (object path, points, counts, widths, curve type, colours, transparency)
    max_samples = 0
    declared: dict = {}

    def visit(obj, world, depth):
        nonlocal max_samples
        if depth > MAX_DEPTH:
            raise FormatError("the object hierarchy nests too deeply", path)
        md = obj.getMetaData()
        if AbcGeom.IXform.matches(md):
            xs = AbcGeom.IXform(obj, wrap).getSchema()
            local = _imath_matrix(xs.getValue(selector).getMatrix())
            world = (world @ local) if xs.getInheritsXforms() else local
            if not np.all(np.isfinite(world)):
                raise FormatError(f"the transform of {obj.getFullName()} is not finite", path)
        elif AbcGeom.ICurves.matches(md):
            schema = AbcGeom.ICurves(obj, wrap).getSchema()
            sample = schema.getValue(selector)
            max_samples = max(max_samples, int(schema.getNumSamples()))
            pts = np.array(sample.getPositions(), dtype=np.float64).reshape(-1, 3)
            counts = np.array(sample.getCurvesNumVertices(), dtype=np.int64).reshape(-1)
            check_counts(pts, counts, obj.getFullName(), path,
                         "nVertices adds up to {total} but P has {points} points")
            widths = None
            wp = schema.getWidthsParam()
            if wp.valid():
                w = np.array(wp.getExpandedValue(selector).getVals(), dtype=np.float64).reshape(-1)
                if len(w) == len(pts):
                    widths = w
                elif len(w) == len(counts):
                    widths = np.repeat(w, counts)
                elif len(w) == 1:
                    widths = np.full(len(pts), w[0])
                elif len(w):
                    raise FormatError(f"{obj.getFullName()}: {len(w)} widths for {len(pts)} points "
                                      f"and {len(counts)} curves", path)
            colors = _arb(schema, selector, "Cs", AbcGeom.IC3fGeomParam, len(pts), counts, 3, obj, path)
            transparency = _arb(schema, selector, "mane_transparency", AbcGeom.IFloatGeomParam, len(pts),
                                counts, 1, obj, path)
            declared.update(_user_strings(schema, ("mane_units", "mane_up")))
            if len(pts):
                p, widths = to_world(pts, widths, world)
                found.append((obj.getFullName(), p, counts, widths, str(sample.getType()), colors,
                              transparency))
        for child in obj.children:
            visit(child, world, depth + 1)

    visit(top, np.eye(4), 0)
    if not found:
        raise FormatError("the archive has no curves (no ICurves object with points)", path)
    points = np.concatenate([f[1] for f in found])
    counts = np.concatenate([f[2] for f in found])
    obj_index = object_index([f[2] for f in found])
    widths = concat([f[3] for f in found])
    colors = concat([f[5] for f in found])
    transparency = concat([f[6] for f in found])
    if not np.all(np.isfinite(points)) or np.abs(points).max() > np.finfo(np.float32).max:
        raise FormatError("curve points are not finite", path)
    if widths is not None and (not np.all(np.isfinite(widths))):
        raise FormatError("curve widths are not finite", path)
    counts, per_point, per_strand, dropped = drop_short_curves(
        counts, path, {"points": points, "widths": widths, "colors": colors, "transparency": transparency},
        {"object": obj_index})
    meta = {"format": "Alembic",
            "alembic": {"objects": [f[0] for f in found], "curve_types": [f[4] for f in found],
                        "num_samples": max_samples, "time": time,
                        "dropped_short_curves": dropped},
            "units": "as stored",
            # Alembic has no units or up axis; most DCCs write Y-up (the unit is guessed) unless
            # mane's user properties on the curves say
            "file_frame": _frame(declared)}
    return build_groom(path, per_point["points"], counts, widths=per_point["widths"],
                       colors=per_point["colors"], transparency=per_point["transparency"],
                       strand_attributes=per_strand, metadata=meta)


def _frame(declared: dict) -> dict:
    units, up = declared.get("mane_units"), declared.get("mane_up")
    out = {"units": None, "units_source": None, "up": "y", "up_source": "convention"}
    if units in ("m", "cm", "mm"):
        out.update(units=units, units_source="declared")
    if up in ("x", "y", "z"):
        out.update(up=up, up_source="declared")
    return out


def _user_strings(schema, names) -> dict:
    from alembic3d import Abc

    props = schema.getUserProperties()
    out = {}
    if props is None or not props.valid():
        return out
    have = {props.getPropertyHeader(i).getName() for i in range(props.getNumProperties())}
    for n in names:
        if n in have:
            try:
                out[n] = str(Abc.IStringProperty(props, n).getValue())
            except Exception:  # noqa: BLE001 - not a string property: not mane's declaration
                pass
    return out


def _arb(schema, selector, name, cls, n_points, counts, width, obj, path):
    """A vertex/uniform/constant arbitrary geometry parameter as (P, width) floats, or None."""
    arb = schema.getArbGeomParams()
    if arb is None or not arb.valid():
        return None
    if name not in {arb.getPropertyHeader(i).getName() for i in range(arb.getNumProperties())}:
        return None
    try:
        vals = cls(arb, name).getExpandedValue(selector).getVals()
        v = np.array([tuple(vals[i]) if width > 1 else vals[i] for i in range(len(vals))], dtype=np.float64)
    except Exception:  # noqa: BLE001 - another type under a known name: ignored
        return None
    v = v.reshape(len(v), width) if width > 1 else v.reshape(-1)
    if len(v) == n_points:
        out = v
    elif len(v) == len(counts):
        out = np.repeat(v, counts, axis=0)
    elif len(v) == 1:
        out = np.repeat(v, n_points, axis=0)
    elif len(v) == 0:
        return None
    else:
        raise FormatError(f"{obj.getFullName()}: {len(v)} {name} values for {n_points} points", path)
    if not np.all(np.isfinite(out)):
        raise FormatError(f"{obj.getFullName()}: {name} values are not finite", path)
    return out


def write(groom: Groom, path) -> None:
    """Write the groom as one linear, non-periodic curves object ``/hair`` (Ogawa)."""
    import imath
    from alembic3d import Abc, AbcGeom

    pts = imath.V3fArrayFromBuffer(np.ascontiguousarray(groom.points, dtype=np.float32))
    nverts = imath.IntArrayFromBuffer(np.ascontiguousarray(groom.counts, dtype=np.int32))
    with atomic_write_path(path) as tmp:
        archive = Abc.OArchive(str(tmp))
        curves = AbcGeom.OCurves(archive.getTop(), "hair")
        if groom.widths is not None:
            w = imath.FloatArrayFromBuffer(np.ascontiguousarray(groom.widths, dtype=np.float32))
            wsample = AbcGeom.OFloatGeomParamSample(w, AbcGeom.GeometryScope.kVertexScope)
            sample = AbcGeom.OCurvesSchemaSample(pts, nverts, AbcGeom.CurveType.kLinear,
                                                 AbcGeom.CurvePeriodicity.kNonPeriodic, wsample)
        else:
            sample = AbcGeom.OCurvesSchemaSample(pts, nverts, AbcGeom.CurveType.kLinear,
                                                 AbcGeom.CurvePeriodicity.kNonPeriodic)
        schema = curves.getSchema()
        schema.set(sample)
        params = []
        if groom.colors is not None:   # "Cs", the DCCs' colour primvar, per vertex
            cs = AbcGeom.OC3fGeomParam(schema.getArbGeomParams(), "Cs", False,
                                       AbcGeom.GeometryScope.kVertexScope, 1)
            arr = imath.C3fArray(groom.num_points)
            for i, c in enumerate(groom.colors.tolist()):
                arr[i] = imath.Color3f(*c)
            cs.set(AbcGeom.OC3fGeomParamSample(arr, AbcGeom.GeometryScope.kVertexScope))
            params.append(cs)
        if groom.transparency is not None:
            tp = AbcGeom.OFloatGeomParam(schema.getArbGeomParams(), "mane_transparency", False,
                                         AbcGeom.GeometryScope.kVertexScope, 1)
            tp.set(AbcGeom.OFloatGeomParamSample(
                imath.FloatArrayFromBuffer(np.ascontiguousarray(groom.transparency, dtype=np.float32)),
                AbcGeom.GeometryScope.kVertexScope))
            params.append(tp)
        for name, value in (("mane_units", "m"), ("mane_up", "y")):   # mane's declaration
            prop = Abc.OStringProperty(schema.getUserProperties(), name)
            prop.setValue(value)
            params.append(prop)
        # Alembic writes the archive when its objects are destroyed: do it before the rename.
        del params, schema, sample, curves, archive
