"""Mesh loaders: small meshes written here (text by hand, binaries with struct), and .tfxmesh."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

import mane
from mane import FormatError, UnsupportedFormatError
from mane.io.meshes import read_mesh

QUAD_V = np.float32([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
QUAD_F = np.int32([[0, 1, 2], [0, 2, 3]])


def test_obj_with_quads_and_colours(tmp_path):
    f = tmp_path / "q.obj"
    f.write_text("# quad\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\nf 1 2 3 4\n")
    m = read_mesh(f)
    assert m.vertices.shape == (4, 3) and m.faces.shape == (2, 3)  # the quad becomes 2 triangles
    np.testing.assert_array_equal(m.vertices, QUAD_V)
    assert m.face_areas().sum() == pytest.approx(1.0)
    assert m.colors is not None
    np.testing.assert_allclose(m.colors[:, :3], [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], atol=1 / 255)


def test_ply_mesh_binary(tmp_path):
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
            "element face 2\nproperty list uchar int vertex_indices\nend_header\n").encode()
    rows = np.zeros(4, dtype=[("p", "<f4", 3), ("c", "u1", 3)])
    rows["p"] = QUAD_V
    rows["c"] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]
    faces = b"".join(struct.pack("<B3i", 3, *f) for f in QUAD_F)
    f = tmp_path / "m.ply"
    f.write_bytes(head + rows.tobytes() + faces)
    m = read_mesh(f)
    np.testing.assert_array_equal(m.vertices, QUAD_V)
    np.testing.assert_array_equal(m.faces, QUAD_F)
    np.testing.assert_allclose(m.colors[:, :3], rows["c"] / 255.0, atol=1e-6)
    f.write_bytes(head.replace(b"face 2", b"face 2000000") + rows.tobytes() + faces)
    with pytest.raises(FormatError, match="truncated"):
        read_mesh(f)


def _stl_binary(tris) -> bytes:
    out = b"\0" * 80 + struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0, 0, 1) + np.float32(t).tobytes() + b"\0\0"
    return out


def test_stl(tmp_path):
    f = tmp_path / "m.stl"
    f.write_bytes(_stl_binary([QUAD_V[[0, 1, 2]], QUAD_V[[0, 2, 3]]]))
    m = read_mesh(f)
    assert len(m.faces) == 2 and m.face_areas().sum() == pytest.approx(1.0)
    f.write_bytes(_stl_binary([QUAD_V[[0, 1, 2]]])[:-10])
    with pytest.raises(FormatError, match="binary STL"):
        read_mesh(f)
    f.write_bytes(b"\0" * 80 + struct.pack("<I", 0xFFFFFFFF))
    with pytest.raises(FormatError, match="needs"):
        read_mesh(f)


def _glb(vertices, faces, translation=(0, 0, 0)) -> bytes:
    vb = np.ascontiguousarray(vertices, "<f4").tobytes()
    ib = np.ascontiguousarray(faces, "<u4").tobytes()
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": list(translation)}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(vb) + len(ib)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(vb)},
                        {"buffer": 0, "byteOffset": len(vb), "byteLength": len(ib)}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
             "min": np.min(vertices, 0).tolist(), "max": np.max(vertices, 0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": int(np.size(faces)), "type": "SCALAR"}],
    }
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binc = vb + ib
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binc), 0x004E4942) + binc
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def test_glb_scene_flattened_with_transform(tmp_path):
    f = tmp_path / "m.glb"
    f.write_bytes(_glb(QUAD_V, QUAD_F, translation=(0, 5, 0)))
    m = read_mesh(f)
    np.testing.assert_allclose(m.vertices, QUAD_V + [0, 5, 0])
    assert len(m.faces) == 2


@pytest.mark.parametrize("mutate,msg", [
    (lambda b: b"glTX" + b[4:], "magic"),
    (lambda b: b[:4] + struct.pack("<I", 1) + b[8:], "version"),
    (lambda b: b[:-4], "header says"),
    (lambda b: b[:12] + struct.pack("<I", 1 << 30) + b[16:], "past the end"),
])
def test_glb_refuses(tmp_path, mutate, msg):
    f = tmp_path / "m.glb"
    f.write_bytes(mutate(_glb(QUAD_V, QUAD_F)))
    with pytest.raises(FormatError, match=msg):
        read_mesh(f)


TFXMESH = """# TressFX collision mesh
numOfBones 2
# bone index, bone name
0 root_JNT
1 head JNT
numOfVertices 4
# vertex index, position, normal, joints, weights
0 0 0 0 0 0 1 0 1 0 0 0.75 0.25 0 0
1 1 0 0 0 0 1 1 0 0 0 1 0 0 0
2 1 1 0 0 0 1 0 0 0 0 1 0 0 0
3 0 1 0 0 0 1 1 1 0 0 0.5 0.5 0 0
numOfTriangles 2
# triangle index, vertex index 0, 1, 2
0 0 1 2
1 0 2 3
"""


def test_tfxmesh(tmp_path):
    f = tmp_path / "b.tfxmesh"
    f.write_text(TFXMESH)
    m = mane.load_mesh(f)
    np.testing.assert_array_equal(m.vertices, QUAD_V)
    np.testing.assert_array_equal(m.faces, QUAD_F)
    np.testing.assert_array_equal(m.normals, np.tile([0, 0, 1], (4, 1)))
    assert m.metadata["bones"] == ["root_JNT", "head JNT"]
    np.testing.assert_array_equal(m.vertex_attributes["joints"][0], [0, 1, 0, 0])
    np.testing.assert_array_equal(m.vertex_attributes["weights"][3], np.float32([0.5, 0.5, 0, 0]))


@pytest.mark.parametrize("old,new,msg", [
    ("numOfBones 2", "numOfBones 5", "line 6: expected .2 <bone name>"),
    ("numOfVertices 4", "numOfVertices 9999999", "only"),
    ("1 0 2 3\n", "1 0 2 9\n", "outside"),
    ("3 0 1 0 0 0 1 1 1", "3 0 1 0 0 0 1 7 1", "joint"),
    ("2 1 1 0 0 0 1 0 0 0 0 1 0 0 0", "2 1 1 0 0 0 1 0 0 0 1 0 0 0", "15 values"),
    ("2 1 1 0 0", "2 nan 1 0 0", "not finite"),
    ("2 1 1 0 0", "5 1 1 0 0", "expected 2"),
    ("1 0 2 3\n", "1 0 2 3\nextra stuff\n", "unexpected"),
    ("0 0 1 2", "0 0 x 2", "whole number"),
])
def test_tfxmesh_refuses(tmp_path, old, new, msg):
    f = tmp_path / "b.tfxmesh"
    f.write_text(TFXMESH.replace(old, new, 1))
    with pytest.raises(FormatError, match=msg):
        mane.load_mesh(f)


@pytest.mark.parametrize("name,content", [
    ("e.obj", b""),
    ("v.obj", b"v 0 0 0\nv 1 0 0\n"),
    ("n.obj", b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("x.glb", b"\0" * 30),
    ("x.gltf", b"{not json"),
    ("x.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n2\n3\n"),
    ("x.stl", b"solid \xff\xfe"),
])
def test_bad_meshes(tmp_path, name, content):
    f = tmp_path / name
    f.write_bytes(content)
    with pytest.raises(FormatError):
        read_mesh(f)


def test_unknown_mesh_suffix(tmp_path):
    with pytest.raises(UnsupportedFormatError):
        read_mesh(tmp_path / "a.fbx")
    with pytest.raises(FormatError, match="no such"):
        read_mesh(tmp_path / "a.obj")
