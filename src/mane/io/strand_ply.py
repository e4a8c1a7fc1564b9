"""Strand PLY: hair as a PLY file with an ``element vertex`` and an ``element strand``.

::

    ply
    format binary_little_endian 1.0        (or: format ascii 1.0)
    comment mane bool immovable             (optional: marks a uchar property as bool)
    element vertex 5
    property float x
    property float y
    property float z
    property float red                      (optional: colour; uchar 0..255 or float 0..1)
    property float green
    property float blue
    property float width                    (optional: strand diameter)
    property float transparency             (optional)
    element strand 2
    property ushort nsegs                   (points = nsegs + 1; or ``nverts``/``vertex_count``)
    end_header

Vertices run strand after strand; the strand counts must add up to the vertex count. Other
scalar properties of ``vertex`` and ``strand`` become point and strand attributes; other
elements (``edge``, ...) are skipped. The header parser here is strict (PLY 1.0 keywords
only, known types, every count checked against the file size before allocating) and is also
used by the mesh loader to check ``.ply`` meshes. ``binary_big_endian`` is refused.
PLY has no units: mane writes ``comment mane units m`` and ``comment mane up y`` and reads
them back as declarations (:mod:`mane.io.units`); other files' units and axes are guessed.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FormatError, GroomError
from ..groom import Groom
from .atomic import atomic_write_path
from .binary import check_finite, read_file_bytes

TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
MAX_HEADER = 1 << 16
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.:\-]*$")
_COUNT_NAMES = {"nsegs": 1, "nseg": 1, "num_segments": 1, "segments": 1,
                "nverts": 0, "nvertices": 0, "vertex_count": 0, "num_vertices": 0, "count": 0}


@dataclass
class Property:
    name: str
    dtype: str  # numpy code without byte order: 'f4'
    list_count: str | None = None  # dtype of a list's length, None for scalars


@dataclass
class Element:
    name: str
    count: int
    properties: list[Property] = field(default_factory=list)

    @property
    def has_lists(self) -> bool:
        return any(p.list_count for p in self.properties)

    def row_dtype(self) -> np.dtype:
        return np.dtype([(p.name, "<" + p.dtype) for p in self.properties])


@dataclass
class Header:
    format: str
    elements: list[Element]
    comments: list[str]
    size: int  # bytes up to and including end_header's newline

    def element(self, name: str) -> Element | None:
        return next((e for e in self.elements if e.name == name), None)


def parse_header(data: bytes, path) -> Header:
    """Parse and check the header (strict: unknown keywords and types are errors)."""
    if not data.startswith(b"ply"):
        raise FormatError("not a PLY file (it does not start with 'ply')", path, 0)
    end = data.find(b"end_header", 0, MAX_HEADER)
    if end < 0:
        raise FormatError("no end_header within the first 64 KiB", path)
    nl = data.find(b"\n", end)
    if nl < 0:
        raise FormatError("truncated: nothing after end_header", path, end)
    if data[end + len(b"end_header"):nl].strip(b"\r \t"):
        raise FormatError("unexpected text after end_header", path, end)
    try:
        text = data[:end].decode("ascii")
    except UnicodeDecodeError as exc:
        raise FormatError("the header is not ASCII", path, exc.start) from None
    lines = text.replace("\r\n", "\n").split("\n")
    if lines[0].strip() != "ply":
        raise FormatError("the first line must be exactly 'ply'", path, 0)
    fmt = None
    elements: list[Element] = []
    comments: list[str] = []
    for i, line in enumerate(lines[1:], 2):
        tokens = line.split()
        if not tokens:
            continue
        key = tokens[0]
        if key == "comment" or key == "obj_info":
            comments.append(line.split(None, 1)[1] if len(tokens) > 1 else "")
        elif key == "format":
            if fmt is not None or elements:
                raise FormatError(f"header line {i}: 'format' must come once, before the elements", path)
            if len(tokens) != 3 or tokens[2] != "1.0":
                raise FormatError(f"header line {i}: expected 'format <kind> 1.0', got {line!r}", path)
            if tokens[1] == "binary_big_endian":
                raise FormatError("binary_big_endian PLY is not supported", path)
            if tokens[1] not in ("ascii", "binary_little_endian"):
                raise FormatError(f"header line {i}: unknown format {tokens[1]!r}", path)
            fmt = tokens[1]
        elif key == "element":
            if fmt is None:
                raise FormatError(f"header line {i}: 'element' before 'format'", path)
            if len(tokens) != 3 or not tokens[2].isdigit() or not _NAME.match(tokens[1]):
                raise FormatError(f"header line {i}: expected 'element <name> <count>', got {line!r}", path)
            if any(e.name == tokens[1] for e in elements):
                raise FormatError(f"header line {i}: element {tokens[1]!r} declared twice", path)
            elements.append(Element(tokens[1], int(tokens[2])))
        elif key == "property":
            if not elements:
                raise FormatError(f"header line {i}: 'property' before any 'element'", path)
            el = elements[-1]
            if len(tokens) == 3 and tokens[1] in TYPES:
                prop = Property(tokens[2], TYPES[tokens[1]])
            elif (len(tokens) == 5 and tokens[1] == "list" and tokens[2] in TYPES
                  and tokens[3] in TYPES and TYPES[tokens[2]][0] in "iu" and TYPES[tokens[3]][0] in "iu"):
                prop = Property(tokens[4], TYPES[tokens[3]], TYPES[tokens[2]])
            else:
                raise FormatError(f"header line {i}: bad property line {line!r}", path)
            if not _NAME.match(prop.name) or any(p.name == prop.name for p in el.properties):
                raise FormatError(f"header line {i}: bad or repeated property name {prop.name!r}", path)
            el.properties.append(prop)
        else:
            raise FormatError(f"header line {i}: unknown keyword {key!r}", path)
    if fmt is None:
        raise FormatError("the header has no 'format' line", path)
    for el in elements:
        if not el.properties:
            raise FormatError(f"element {el.name!r} has no properties", path)
    return Header(fmt, elements, comments, nl + 1)


def read_elements(data: bytes, header: Header, path) -> dict[str, dict]:
    """Every element's properties: scalars as arrays, lists as ``(lengths, flat values)`` tuples.

    Counts are checked against the bytes (or tokens) left before anything is allocated, and
    the body must end exactly where the last element does."""
    if header.format == "ascii":
        return _read_ascii(data, header, path)
    return _read_binary(data, header, path)


def _read_binary(data: bytes, header: Header, path):
    pos = header.size
    out = {}
    for el in header.elements:
        if not el.has_lists:
            dt = el.row_dtype()
            need = el.count * dt.itemsize
            if need > len(data) - pos:
                raise FormatError(
                    f"truncated: element {el.name!r} declares {el.count} rows ({need} bytes) but "
                    f"{len(data) - pos} bytes are left", path, pos)
            rows = np.frombuffer(data, dtype=dt, count=el.count, offset=pos)
            out[el.name] = {p.name: np.ascontiguousarray(rows[p.name]) for p in el.properties}
            pos += need
            continue
        # Rows of variable size: walk them (each row takes at least one byte).
        if el.count > len(data) - pos:
            raise FormatError(f"truncated: element {el.name!r} declares {el.count} rows but "
                              f"{len(data) - pos} bytes are left", path, pos)
        fast = _binary_fixed_lists(data, pos, el)
        if fast is not None:   # every row's lists as long as the first row's: one frombuffer
            out[el.name], pos = fast
            continue
        cols: dict[str, list] = {p.name: [] for p in el.properties}
        for r in range(el.count):
            for p in el.properties:
                if p.list_count:
                    ct = np.dtype("<" + p.list_count)
                    if pos + ct.itemsize > len(data):
                        raise FormatError(f"truncated in element {el.name!r} row {r}", path, pos)
                    n = int(np.frombuffer(data, ct, 1, pos)[0])
                    pos += ct.itemsize
                    it = np.dtype("<" + p.dtype)
                    if n < 0 or pos + n * it.itemsize > len(data):
                        raise FormatError(f"truncated or bad list length {n} in element "
                                          f"{el.name!r} row {r}", path, pos)
                    cols[p.name].append(np.frombuffer(data, it, n, pos))
                    pos += n * it.itemsize
                else:
                    it = np.dtype("<" + p.dtype)
                    if pos + it.itemsize > len(data):
                        raise FormatError(f"truncated in element {el.name!r} row {r}", path, pos)
                    cols[p.name].append(np.frombuffer(data, it, 1, pos)[0])
                    pos += it.itemsize
        out[el.name] = {p.name: _finish_column(p, cols[p.name]) for p in el.properties}
    if pos != len(data):
        raise FormatError(f"{len(data) - pos} unexpected bytes after the last element", path, pos)
    return out


def _binary_fixed_lists(data: bytes, pos: int, el: Element):
    """Vectorised read of an element whose rows all have the first row's list lengths (faces of
    one polygon size, fixed-length strands): (columns, new position), or None to walk the rows."""
    if el.count == 0:
        return None
    fields, at = [], pos
    for p in el.properties:
        if p.list_count:
            ct = np.dtype("<" + p.list_count)
            if at + ct.itemsize > len(data):
                return None
            n = int(np.frombuffer(data, ct, 1, at)[0])
            it = np.dtype("<" + p.dtype)
            if n < 0 or n > len(data):
                return None
            fields += [("__mane_count_" + p.name, ct), (p.name, it, (n,))]
            at += ct.itemsize + n * it.itemsize
        else:
            fields.append((p.name, np.dtype("<" + p.dtype)))
            at += np.dtype(p.dtype).itemsize
    dt = np.dtype(fields)
    if el.count * dt.itemsize > len(data) - pos:
        return None
    rows = np.frombuffer(data, dtype=dt, count=el.count, offset=pos)
    cols = {}
    for p in el.properties:
        if p.list_count:
            n = dt[p.name].shape[0] if dt[p.name].shape else 1
            if np.any(rows["__mane_count_" + p.name] != n):
                return None
            flat = np.ascontiguousarray(rows[p.name]).reshape(-1).astype(np.dtype(p.dtype))
            cols[p.name] = (np.full(el.count, n, dtype=np.int64), flat)
        else:
            cols[p.name] = np.ascontiguousarray(rows[p.name]).astype(np.dtype(p.dtype))
    return cols, pos + el.count * dt.itemsize


def _ascii_fixed_lists(tokens, at: int, el: Element, path):
    """The ASCII twin of ``_binary_fixed_lists``: (columns, new token index) or None."""
    if el.count == 0:
        return None
    width, lengths, k = 0, {}, at
    for p in el.properties:
        if p.list_count:
            if k >= len(tokens):
                return None
            try:
                n = int(tokens[k])
            except ValueError:
                return None
            if n < 0:
                return None
            lengths[p.name] = n
            width += 1 + n
            k += 1 + n
        else:
            width += 1
            k += 1
    need = el.count * width
    if need > len(tokens) - at:
        return None
    block = _numbers(tokens[at:at + need], path, el.name).reshape(el.count, width)
    cols, c = {}, 0
    for p in el.properties:
        if p.list_count:
            n = lengths[p.name]
            if np.any(block[:, c] != n):
                return None
            flat = _cast(block[:, c + 1:c + 1 + n].reshape(-1), p, path, el.name)
            cols[p.name] = (np.full(el.count, n, dtype=np.int64), flat)
            c += 1 + n
        else:
            cols[p.name] = _cast(block[:, c], p, path, el.name)
            c += 1
    return cols, at + need


def _finish_column(p: Property, values):
    if p.list_count:
        lengths = np.array([len(v) for v in values], dtype=np.int64)
        flat = np.concatenate(values) if values else np.zeros(0, dtype=p.dtype)
        return (lengths, flat)
    return np.array(values, dtype=p.dtype)


def _read_ascii(data: bytes, header: Header, path):
    try:
        text = data[header.size:].decode("ascii")
    except UnicodeDecodeError as exc:
        raise FormatError("the ASCII body has non-ASCII bytes", path, header.size + exc.start) from None
    tokens = text.split()
    at = 0
    out = {}
    for el in header.elements:
        if not el.has_lists:
            width = len(el.properties)
            need = el.count * width
            if need > len(tokens) - at:
                raise FormatError(
                    f"truncated: element {el.name!r} declares {el.count} rows of {width} values "
                    f"but {len(tokens) - at} values are left", path)
            block = _numbers(tokens[at:at + need], path, el.name).reshape(el.count, width)
            at += need
            out[el.name] = {p.name: _cast(block[:, k], p, path, el.name)
                            for k, p in enumerate(el.properties)}
            continue
        if el.count > len(tokens) - at:
            raise FormatError(f"truncated: element {el.name!r} declares {el.count} rows", path)
        fast = _ascii_fixed_lists(tokens, at, el, path)
        if fast is not None:   # every row's lists as long as the first row's: one block
            out[el.name], at = fast
            continue
        cols: dict[str, list] = {p.name: [] for p in el.properties}
        for r in range(el.count):
            for p in el.properties:
                if at >= len(tokens):
                    raise FormatError(f"truncated in element {el.name!r} row {r}", path)
                if p.list_count:
                    n = _int_token(tokens[at], path, el.name)
                    at += 1
                    if n < 0 or n > len(tokens) - at:
                        raise FormatError(f"bad list length {n} in element {el.name!r} row {r}", path)
                    cols[p.name].append(_cast(_numbers(tokens[at:at + n], path, el.name), p, path, el.name))
                    at += n
                else:
                    cols[p.name].append(_cast(_numbers(tokens[at:at + 1], path, el.name), p, path, el.name)[0])
                    at += 1
        out[el.name] = {p.name: _finish_column(p, cols[p.name]) for p in el.properties}
    if at != len(tokens):
        raise FormatError(f"{len(tokens) - at} unexpected values after the last element", path)
    return out


def _int_token(tok: str, path, what) -> int:
    try:
        return int(tok)
    except ValueError:
        raise FormatError(f"element {what!r}: expected a whole number, got {tok[:40]!r}", path) from None


def _numbers(tokens, path, what) -> np.ndarray:
    try:
        return np.array(tokens, dtype=np.float64)
    except (ValueError, OverflowError):
        bad = next((t for t in tokens if not _is_number(t)), "?")
        raise FormatError(f"element {what!r}: {bad[:40]!r} is not a number", path) from None


def _is_number(t: str) -> bool:
    try:
        float(t)
        return True
    except ValueError:
        return False


def _cast(values: np.ndarray, p: Property, path, what) -> np.ndarray:
    dt = np.dtype(p.dtype)
    if dt.kind == "f":
        return values.astype(dt)
    if not np.all(np.isfinite(values)) or np.any(values != np.round(values)):
        raise FormatError(f"element {what!r} property {p.name!r}: expected whole numbers", path)
    info = np.iinfo(dt)
    if values.size and (values.min() < info.min or values.max() > info.max):
        raise FormatError(f"element {what!r} property {p.name!r}: value out of range for {dt}", path)
    return values.astype(dt)


def read_header(path) -> Header:
    """Only the header (for ``mane info`` to tell strand files from meshes)."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_HEADER + 64)
    except OSError as exc:
        raise FormatError(f"cannot read the file ({exc.strerror or exc})", path) from None
    return parse_header(data, path)


# ---------------------------------------------------------------------------- hair
_VERTEX_CORE = {"x", "y", "z", "red", "green", "blue", "r", "g", "b", "width", "transparency"}


def read(path) -> Groom:
    path = Path(path)
    data = read_file_bytes(path)
    header = parse_header(data, path)
    vertex, strand = header.element("vertex"), header.element("strand")
    if vertex is None:
        raise FormatError("no 'element vertex'", path)
    if strand is None:
        face = header.element("face")
        hint = " (it has faces: it is a mesh, read it with mane.load_mesh)" if face else ""
        raise FormatError("no 'element strand': not a strand PLY" + hint, path)
    names = {p.name for p in vertex.properties}
    if not {"x", "y", "z"} <= names:
        raise FormatError("element vertex needs properties x, y and z", path)
    if any(p.list_count for p in vertex.properties):
        raise FormatError("element vertex must not have list properties", path)
    count_props = [p for p in strand.properties if p.name in _COUNT_NAMES and not p.list_count]
    if len(count_props) != 1 or strand.has_lists:
        raise FormatError(
            "element strand needs exactly one scalar count property "
            f"(one of {', '.join(sorted(_COUNT_NAMES))}) and no lists", path)
    if vertex.count == 0 or strand.count == 0:
        raise FormatError(f"the file holds no hair ({vertex.count} vertices, {strand.count} strands)", path)
    # The smallest possible body, checked before anything is allocated.
    if header.format == "binary_little_endian":
        min_body = sum(e.count * (e.row_dtype().itemsize if not e.has_lists else 1)
                       for e in header.elements)
        if min_body > len(data) - header.size:
            raise FormatError(f"truncated: the header's elements need at least {min_body} bytes "
                              f"but the body has {len(data) - header.size}", path, header.size)
    else:
        if sum(e.count for e in header.elements) > len(data) - header.size:
            raise FormatError("truncated: the header declares more rows than the body can hold", path,
                              header.size)
    elements = read_elements(data, header, path)
    v, s = elements["vertex"], elements["strand"]
    cp = count_props[0]
    raw_counts = s[cp.name].astype(np.int64)
    counts = raw_counts + _COUNT_NAMES[cp.name]
    if (raw_counts < 0).any():
        raise FormatError(f"a strand has a negative {cp.name}", path)
    if int(counts.sum()) != vertex.count:
        raise FormatError(f"the strands add up to {int(counts.sum())} vertices "
                          f"({cp.name}{' + 1' if _COUNT_NAMES[cp.name] else ''} each) "
                          f"but element vertex has {vertex.count}", path)
    points = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)
    check_finite(points, "vertex positions", path)
    if np.abs(points).max() > np.finfo(np.float32).max:
        raise FormatError("vertex positions overflow float32", path)
    colors = None
    rgb = next((t for t in (("red", "green", "blue"), ("r", "g", "b")) if set(t) <= names), None)
    if rgb:
        cols = [v[c] for c in rgb]
        if cols[0].dtype.kind in "iu":
            colors = np.stack(cols, axis=1).astype(np.float32) / np.float32(255.0)
        else:
            colors = np.stack(cols, axis=1).astype(np.float32)
            check_finite(colors, "vertex colours", path)
    widths = v.get("width")
    transparency = v.get("transparency")
    for name, arr in (("width", widths), ("transparency", transparency)):
        if arr is not None:
            check_finite(arr, name, path)
    bools = {c.split()[2] for c in header.comments if c.startswith("mane bool ") and len(c.split()) == 3}
    used = {"x", "y", "z", "width", "transparency"} | (set(rgb) if rgb else set())
    point_attrs = {n: (a != 0 if n in bools else a) for n, a in v.items() if n not in used}
    strand_attrs = {n: (a != 0 if n in bools else a) for n, a in s.items() if n != cp.name}
    for n, a in list(point_attrs.items()) + list(strand_attrs.items()):
        if a.dtype.kind == "f":
            check_finite(a, f"property {n}", path)
    meta = {"format": "strand PLY",
            "ply": {"encoding": header.format, "count_property": cp.name,
                    "elements": {e.name: e.count for e in header.elements},
                    "comments": [c for c in header.comments
                                 if not c.startswith(("mane bool ", "mane units ", "mane up "))][:50]},
            "up_axis": "y", "units": "as stored", "file_frame": _frame(header.comments)}
    try:
        return Groom(points.astype(np.float32), counts,
                     widths=None if widths is None else widths.astype(np.float32),
                     colors=colors,
                     transparency=None if transparency is None else transparency.astype(np.float32),
                     point_attributes=point_attrs, strand_attributes=strand_attrs, metadata=meta)
    except GroomError as exc:
        raise FormatError(str(exc), path) from None


def _frame(comments: list[str]) -> dict:
    """``comment mane units U`` / ``comment mane up A`` (mane's writer) as declarations."""
    out = {"units": None, "units_source": None, "up": None, "up_source": None}
    for c in comments:
        t = c.split()
        if len(t) == 3 and t[:2] == ["mane", "units"] and t[2] in ("m", "cm", "mm"):
            out.update(units=t[2], units_source="declared")
        if len(t) == 3 and t[:2] == ["mane", "up"] and t[2] in ("x", "y", "z"):
            out.update(up=t[2], up_source="declared")
    return out


_PLY_TYPE = {"i1": "char", "u1": "uchar", "i2": "short", "u2": "ushort", "i4": "int", "u4": "uint",
             "f4": "float", "f8": "double"}


def _ply_column(name: str, arr: np.ndarray, bools: list[str]):
    arr = np.asarray(arr)
    if arr.ndim != 1 or not _NAME.match(name) or arr.dtype.kind not in "biuf":
        return None
    if arr.dtype.kind == "b":
        bools.append(name)
        arr = arr.astype(np.uint8)
    elif arr.dtype.kind in "iu" and arr.dtype.itemsize == 8:
        arr = arr.astype(np.int32 if arr.dtype.kind == "i" else np.uint32)
    elif arr.dtype.kind == "f" and arr.dtype.itemsize == 2:
        arr = arr.astype(np.float32)
    return name, arr


def write(groom: Groom, path, binary: bool = True) -> None:
    """Write a strand PLY (binary little-endian by default, ``binary=False`` for ASCII).

    Positions, colours, widths and transparency are float32 (exact); 1-D numeric point and
    strand attributes go along as extra properties (bool ones as uchar, marked in a comment).
    Attributes of other shapes are not written.
    """
    bools: list[str] = []
    vcols = [("x", groom.points[:, 0]), ("y", groom.points[:, 1]), ("z", groom.points[:, 2])]
    if groom.colors is not None:
        vcols += [("red", groom.colors[:, 0]), ("green", groom.colors[:, 1]), ("blue", groom.colors[:, 2])]
    if groom.widths is not None:
        vcols.append(("width", groom.widths))
    if groom.transparency is not None:
        vcols.append(("transparency", groom.transparency))
    taken = {n for n, _ in vcols}
    for name, arr in groom.point_attributes.items():
        col = _ply_column(name, arr, bools) if name not in _VERTEX_CORE | taken else None
        if col:
            vcols.append(col)
    nsegs = groom.counts.astype(np.int64) - 1
    scols = [("nsegs", nsegs.astype(np.uint16 if nsegs.max() <= 0xFFFF else np.uint32))]
    for name, arr in groom.strand_attributes.items():
        col = _ply_column(name, arr, bools) if name not in _COUNT_NAMES else None
        if col:
            scols.append(col)
    lines = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
             "comment written by mane", "comment mane units m", "comment mane up y"]
    lines += [f"comment mane bool {b}" for b in bools]
    lines.append(f"element vertex {groom.num_points}")
    lines += [f"property {_PLY_TYPE[a.dtype.str[1:]]} {n}" for n, a in vcols]
    lines.append(f"element strand {groom.num_strands}")
    lines += [f"property {_PLY_TYPE[a.dtype.str[1:]]} {n}" for n, a in scols]
    lines.append("end_header")
    head = ("\n".join(lines) + "\n").encode("ascii")
    with atomic_write_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(head)
            for cols in (vcols, scols):
                if binary:
                    dt = np.dtype([(n, "<" + a.dtype.str[1:]) for n, a in cols])
                    rows = np.empty(len(cols[0][1]), dtype=dt)
                    for n, a in cols:
                        rows[n] = a
                    fh.write(rows.tobytes())
                else:
                    fmts = ["%.9g" if a.dtype.kind == "f" else "%d" for _, a in cols]
                    table = np.empty((len(cols[0][1]), len(cols)), dtype=object)
                    for k, (_, a) in enumerate(cols):
                        table[:, k] = a.astype(np.float64 if a.dtype.kind == "f" else np.int64)
                    np.savetxt(fh, table, fmt=fmts, delimiter=" ")
