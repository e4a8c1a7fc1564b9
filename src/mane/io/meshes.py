"""Head and body meshes: OBJ, PLY, GLB/glTF and STL through trimesh, and TressFX ``.tfxmesh``.

``read_mesh(path) -> Mesh``. trimesh loads with ``process=False`` so vertices are neither
merged nor reordered (counts match what the file says); a GLB/glTF scene is flattened with
every node's transform applied. Vertex colours are kept (as RGBA in [0, 1]); texture-mapped
colour is not sampled. Polygons are triangulated by trimesh. The numbers are kept as stored;
``metadata['file_frame']`` says what the format says (glTF: Y-up by definition, metres by
convention; ``.tfxmesh``: TressFX's centimetres, Y-up; OBJ/PLY/STL: nothing) and
:func:`mane.io.load_mesh` turns the mesh to metres, Y up (:mod:`mane.io.units`).

Before trimesh sees a binary file its framing is checked here: a binary STL's triangle count
against the file size, a GLB's header and chunk lengths, a PLY's header with the strict parser
of :mod:`mane.io.strand_ply`; every failure is a FormatError.

``.tfxmesh`` (TressFX collision mesh, ASCII, ``#`` comments)::

    numOfBones N
    <index> <bone name>                      N lines
    numOfVertices V
    <index> x y z nx ny nz j0 j1 j2 j3 w0 w1 w2 w3     V lines (4 joint indices, 4 weights)
    numOfTriangles F
    <index> a b c                            F lines

It becomes a Mesh with the file's normals, ``vertex_attributes`` ``joints`` (V, 4) int32 and
``weights`` (V, 4) float32, and the bone names in ``metadata['bones']``.
"""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from ..errors import FormatError, GroomError, UnsupportedFormatError, not_a_file
from ..mesh import Mesh
from .binary import read_file_bytes

TRIMESH_SUFFIXES = (".obj", ".ply", ".glb", ".gltf", ".stl")
MESH_SUFFIXES = TRIMESH_SUFFIXES + (".tfxmesh",)


def read_mesh(path) -> Mesh:
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise UnsupportedFormatError(
            f"{path}: cannot read {suffix or 'files without a suffix'} meshes; "
            f"supported: {', '.join(MESH_SUFFIXES)}")
    if not path.is_file():
        raise not_a_file(path)
    try:
        if suffix == ".tfxmesh":
            return read_tfxmesh(path)
        return _read_trimesh(path, suffix)
    except (FormatError, UnsupportedFormatError):
        raise
    except GroomError as exc:
        raise FormatError(str(exc), path) from None
    except MemoryError:
        raise FormatError("the file asks for more memory than this machine has", path) from None
    except RecursionError:
        raise FormatError("the file nests too deeply", path) from None
    except (ValueError, IndexError, TypeError, KeyError, AttributeError, OverflowError) as exc:
        # trimesh's post-processing (normals, colours, reshapes) on a malformed file
        raise FormatError(f"cannot read the mesh ({type(exc).__name__}: {str(exc)[:200]})", path) from None


# ---------------------------------------------------------------------------- trimesh formats
def _check_stl(data: bytes, path) -> None:
    if len(data) >= 84:
        n = struct.unpack_from("<I", data, 80)[0]
        if 84 + 50 * n == len(data):
            return  # a well-formed binary STL
    head = data[:5].lower()
    if head == b"solid":
        try:
            data.decode("ascii")
        except UnicodeDecodeError as exc:
            raise FormatError("an ASCII STL ('solid ...') with non-ASCII bytes", path, exc.start) from None
        return
    if len(data) < 84:
        raise FormatError(f"truncated: a binary STL needs at least 84 bytes, the file has {len(data)}", path)
    n = struct.unpack_from("<I", data, 80)[0]
    raise FormatError(f"a binary STL declaring {n} triangles needs {84 + 50 * n} bytes, the file has "
                      f"{len(data)}", path, 80)


def _check_glb(data: bytes, path) -> None:
    if len(data) < 12 or data[:4] != b"glTF":
        raise FormatError(f"not a GLB file (magic {data[:4]!r}, expected b'glTF')", path, 0)
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise FormatError(f"GLB version {version}; only glTF 2 is supported", path, 4)
    if length != len(data):
        raise FormatError(f"the GLB header says {length} bytes, the file has {len(data)}", path, 8)
    pos = 12
    chunks = 0
    while pos < len(data):
        if pos + 8 > len(data):
            raise FormatError("truncated chunk header", path, pos)
        clen, ctype = struct.unpack_from("<II", data, pos)
        if clen > len(data) - pos - 8:
            raise FormatError(f"a chunk declares {clen} bytes, past the end of the file", path, pos)
        if chunks == 0:
            if ctype != 0x4E4F534A:  # 'JSON'
                raise FormatError("the first GLB chunk is not JSON", path, pos)
            try:
                doc = json.loads(data[pos + 8:pos + 8 + clen].decode("utf-8"))
            except (UnicodeDecodeError, ValueError, RecursionError) as exc:
                raise FormatError(f"the GLB's JSON chunk is invalid ({str(exc)[:100]})", path, pos + 8) from None
            _check_gltf_json(doc, path)
        pos += 8 + clen
        chunks += 1
    if chunks == 0:
        raise FormatError("the GLB has no chunks", path, 12)


def _check_gltf_json(doc, path) -> None:
    if not isinstance(doc, dict):
        raise FormatError("the glTF JSON is not an object", path)
    for key in ("meshes", "accessors", "bufferViews", "buffers", "nodes", "scenes"):
        if key in doc and not isinstance(doc[key], list):
            raise FormatError(f"glTF '{key}' must be a list", path)
    for acc in doc.get("accessors", []):
        if not isinstance(acc, dict) or not isinstance(acc.get("count", 0), int) or acc.get("count", 0) < 0:
            raise FormatError("a glTF accessor has a bad count", path)
    for buf in doc.get("buffers", []):
        if not isinstance(buf, dict):
            raise FormatError("a glTF buffer is not an object", path)
        uri = buf.get("uri")
        if isinstance(uri, str) and ("://" in uri and not uri.startswith("data:")):
            raise FormatError("glTF buffers must be local files or data URIs", path)


def _check_obj(data: bytes, path) -> None:
    if b"\0" in data[:4096]:
        raise FormatError("an OBJ file is text, this one has NUL bytes", path, data.index(b"\0"))


def _read_trimesh(path: Path, suffix: str) -> Mesh:
    import trimesh

    data = read_file_bytes(path)
    if not data:
        raise FormatError("the file is empty", path)
    if suffix == ".stl":
        _check_stl(data, path)
    elif suffix == ".glb":
        _check_glb(data, path)
    elif suffix == ".gltf":
        try:
            doc = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            raise FormatError(f"not glTF JSON ({str(exc)[:100]})", path) from None
        _check_gltf_json(doc, path)
    elif suffix == ".ply":
        from . import strand_ply

        header = strand_ply.parse_header(data, path)
        if header.element("face") is None:
            hint = " (it has strands: read it with mane.load)" if header.element("strand") else ""
            raise FormatError("a PLY mesh needs an 'element face'" + hint, path)
        strand_ply.read_elements(data, header, path)  # checks every count against the file
    elif suffix == ".obj":
        _check_obj(data, path)
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False, skip_materials=suffix == ".obj")
    except (FormatError, UnsupportedFormatError):
        raise
    except Exception as exc:  # trimesh raises anything on a bad file
        raise FormatError(f"cannot read the mesh ({type(exc).__name__}: {str(exc)[:200]})", path) from None
    if isinstance(loaded, trimesh.Scene):  # force='mesh' on an empty scene
        raise FormatError("the file holds no mesh geometry", path)
    vertices = np.asarray(loaded.vertices, dtype=np.float64)
    faces = np.asarray(loaded.faces, dtype=np.int64)
    if len(vertices) == 0 or faces.size == 0:
        raise FormatError(f"the mesh is empty ({len(vertices)} vertices, {len(faces)} faces)", path)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise FormatError(f"faces have shape {faces.shape}, expected triangles", path)
    if not np.all(np.isfinite(vertices)) or np.abs(vertices).max() > np.finfo(np.float32).max:
        raise FormatError("mesh vertices contain NaN, infinite or out-of-range values", path)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise FormatError(f"faces index vertices up to {int(faces.max())} but there are {len(vertices)}",
                          path)
    colors = None
    visual = getattr(loaded, "visual", None)
    if visual is not None and getattr(visual, "kind", None) == "vertex":
        vc = np.asarray(visual.vertex_colors)
        if vc.ndim == 2 and len(vc) == len(vertices) and vc.shape[1] in (3, 4):
            colors = vc.astype(np.float32) / (255.0 if vc.dtype.kind in "iu" else 1.0)
    normals = None  # computed by Mesh from the faces: OBJ normals are per corner, not per vertex
    meta = {"format": suffix.lstrip(".").upper(), "source": str(path)}
    if suffix in (".glb", ".gltf"):  # glTF 2: Y-up (the spec), metres (often not kept: checked)
        meta["file_frame"] = {"units": "m", "units_source": "convention", "up": "y", "up_source": "declared"}
    return Mesh(vertices.astype(np.float32), faces.astype(np.int32), normals, colors, metadata=meta)


# ---------------------------------------------------------------------------- .tfxmesh
def read_tfxmesh(path) -> Mesh:
    path = Path(path)
    data = read_file_bytes(path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FormatError("not a text file (not UTF-8)", path, exc.start) from None
    lines = [(i, ln.split("#", 1)[0].split()) for i, ln in enumerate(text.splitlines(), 1)]
    lines = [(i, t) for i, t in lines if t]
    at = 0

    def section(keyword):
        nonlocal at
        if at >= len(lines):
            raise FormatError(f"truncated: expected '{keyword} N'", path)
        lineno, tokens = lines[at]
        if len(tokens) != 2 or tokens[0] != keyword or not tokens[1].isdigit():
            raise FormatError(f"line {lineno}: expected '{keyword} N', got {' '.join(tokens)[:80]!r}", path)
        n = int(tokens[1])
        if n > len(lines) - at - 1:
            raise FormatError(f"line {lineno}: {keyword} is {n} but only {len(lines) - at - 1} lines follow",
                              path)
        at += 1
        rows = lines[at:at + n]
        at += n
        return lineno, rows

    def numbered_section(keyword, plural, columns, needs):
        """A section's lines, at least one, each of ``columns`` tokens (``needs`` says what they are)."""
        kline, rows = section(keyword)
        if not rows:
            raise FormatError(f"line {kline}: the mesh has no {plural}", path)
        for lineno, tokens in rows:
            if len(tokens) != columns:
                raise FormatError(f"line {lineno}: {needs}, got {len(tokens)}", path)
        return rows

    def check_numbering(rows, index, what, spec):
        """FormatError unless the first column counts 0, 1, 2, ..."""
        if not np.array_equal(index, np.arange(len(rows))):
            row = int(np.argmax(index != np.arange(len(rows))))
            raise FormatError(f"line {rows[row][0]}: {what} index {index[row]:{spec}}, expected {row}", path)

    _, bone_rows = section("numOfBones")
    bones = []
    for k, (lineno, tokens) in enumerate(bone_rows):
        if len(tokens) < 2 or tokens[0] != str(k):
            raise FormatError(f"line {lineno}: expected '{k} <bone name>'", path)
        bones.append(" ".join(tokens[1:]))
    vrows = numbered_section("numOfVertices", "vertices", 15,
                             "a vertex line needs 15 values (index, position, normal, 4 joints, 4 weights)")
    try:
        table = np.array([t for _, t in vrows], dtype=np.float64)
    except ValueError:
        raise FormatError(f"lines {vrows[0][0]}..{vrows[-1][0]}: a vertex value is not a number", path) from None
    if not np.all(np.isfinite(table)):
        row = int(np.argmax(~np.isfinite(table).all(axis=1)))
        raise FormatError(f"line {vrows[row][0]}: a vertex value is not finite", path)
    check_numbering(vrows, table[:, 0], "vertex", "g")
    joints = table[:, 7:11]
    if np.any(joints != np.round(joints)) or joints.min() < 0 or (bones and joints.max() >= len(bones)):
        row = int(np.argmax(((joints != np.round(joints)) | (joints < 0)
                             | (joints >= max(len(bones), 1))).any(axis=1)))
        raise FormatError(f"line {vrows[row][0]}: joint indices must be bone numbers 0..{len(bones) - 1}",
                          path)
    if np.abs(table[:, 1:7]).max() > np.finfo(np.float32).max:
        raise FormatError("vertex values overflow float32", path)
    frows = numbered_section("numOfTriangles", "triangles", 4,
                             "a triangle line needs 4 whole numbers (index, 3 vertex indices)")
    try:
        tri = np.array([[int(x) for x in t] for _, t in frows], dtype=np.int64)
    except ValueError:
        raise FormatError(f"lines {frows[0][0]}..{frows[-1][0]}: a triangle value is not a whole number",
                          path) from None
    check_numbering(frows, tri[:, 0], "triangle", "")
    faces = tri[:, 1:]
    if faces.min() < 0 or faces.max() >= len(vrows):
        row = int(np.argmax(((faces < 0) | (faces >= len(vrows))).any(axis=1)))
        raise FormatError(f"line {frows[row][0]}: a vertex index is outside 0..{len(vrows) - 1}", path)
    if at != len(lines):
        lineno, tokens = lines[at]
        raise FormatError(f"line {lineno}: unexpected text after the triangles: {' '.join(tokens)[:80]!r}",
                          path)
    return Mesh(table[:, 1:4].astype(np.float32), faces.astype(np.int32),
                normals=table[:, 4:7].astype(np.float32),
                vertex_attributes={"joints": joints.astype(np.int32),
                                   "weights": table[:, 11:15].astype(np.float32)},
                metadata={"format": "tfxmesh", "bones": bones, "source": str(path),
                          "file_frame": {"units": "cm", "units_source": "convention", "up": "y",
                                         "up_source": "convention"}})
