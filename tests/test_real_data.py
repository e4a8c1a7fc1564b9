"""Every loader on the real files in ../shared/data, against the counts its README lists."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

import mane
from mane.app.cli import main

pytestmark = pytest.mark.data

# file, strands, vertices per strand, immovable vertices per strand (the README / the spec)
TFX = [
    ("tressfx/Ratboy_mohawk.tfx", 2226, 32, 2),   # v4: w == 0 on the first 2 of every strand
    ("tressfx/sintel_hair.tfx", 228, 32, 1),      # v4: w == 0 on the first of every strand
    ("tressfx/bear_v3.tfx", 48113, 4, 2),         # v3: TressFX 3 pins the first 2
]


@pytest.mark.parametrize("name,strands,verts,pinned", TFX)
def test_tfx_counts(shared_data, name, strands, verts, pinned):
    path = shared_data / name
    g = mane.load(path, units="m", up="y")   # the numbers as stored
    assert g.num_strands == strands and g.num_points == strands * verts
    assert g.uniform_count == verts
    imm = g.point_attributes["immovable"].reshape(strands, verts)
    assert imm[:, :pinned].all() and not imm[:, pinned:].any()
    # Positions straight from the file with NumPy, per the spec's header layout.
    raw = path.read_bytes()
    version = struct.unpack_from("<f", raw)[0]
    if version == 4.0:
        off = struct.unpack_from("<I", raw, 12)[0]
        pos = np.frombuffer(raw, "<f4", strands * verts * 4, off).reshape(-1, 4)
        np.testing.assert_array_equal(g.points, pos[:, :3])
        np.testing.assert_array_equal(g.point_attributes["immovable"], pos[:, 3] == 0)
    else:
        off = struct.unpack_from("<I", raw, 144)[0]
        np.testing.assert_array_equal(g.points, np.frombuffer(raw, "<f4", strands * verts * 3, off).reshape(-1, 3))


def test_ratboy_strand_uvs(shared_data):
    g = mane.load(shared_data / "tressfx/Ratboy_mohawk.tfx")
    uv = g.strand_attributes["uv"]
    assert uv.shape == (2226, 2) and np.all((uv >= 0) & (uv <= 1))


def test_ponytail_project(shared_data):
    folder = shared_data / "tressfx/v3_ponytail"
    g = mane.load(folder / "ponytail.tfxproj")
    assert g.num_strands == 4933 and g.uniform_count == 16
    project = g.metadata["tressfx_project"]
    assert [p["file"] for p in project["parts"]] == ["front_top.tfx", "side.tfx", "back.tfx", "tail.tfx"]
    assert len(project["collision_spheres"]) == 3
    assert project["collision_spheres"][0] == {"center": [-0.095, 92.0, 9.899], "radius": 26.5}
    parts = [mane.load(folder / p["file"]) for p in project["parts"]]
    assert sum(p.num_strands for p in parts) == 4933
    np.testing.assert_array_equal(g.points, np.concatenate([p.points for p in parts]))
    assert np.bincount(g.strand_attributes["part"]).tolist() == [p.num_strands for p in parts]
    # back.tfx sets bothEndsImmovable: its last two vertices are pinned too.
    back = mane.load(folder / "back.tfx")
    assert back.metadata["tressfx"]["both_ends_immovable"]
    imm = back.point_attributes["immovable"].reshape(-1, 16)
    assert imm[:, [0, 1, 14, 15]].all() and not imm[:, 2:14].any()
    json.dumps(g.metadata)


# file, vertices, faces. sintel.obj: every OBJ face is already a triangle (5,952 'f' lines of
# 3 corners), so the triangulated count equals the README's face count.
MESHES = [
    ("tressfx/Ratboy_body.tfxmesh", 12909, 25814),
    ("heads/sintel.obj", 3046, 5952),
    ("heads/LeePerrySmith.glb", 9279, 17684),
]


@pytest.mark.parametrize("name,verts,faces", MESHES)
def test_mesh_counts(shared_data, name, verts, faces):
    m = mane.load_mesh(shared_data / name)
    assert len(m.vertices) == verts and len(m.faces) == faces


def test_sintel_obj_faces_are_triangles(shared_data):
    lines = (shared_data / "heads/sintel.obj").read_text().splitlines()
    corners = [len(ln.split()) - 1 for ln in lines if ln.startswith("f ")]
    assert len(corners) == 5952 and set(corners) == {3}


def test_ratboy_body_skinning(shared_data):
    m = mane.load_mesh(shared_data / "tressfx/Ratboy_body.tfxmesh")
    assert len(m.metadata["bones"]) == 86
    w = m.vertex_attributes["weights"]
    assert w.shape == (12909, 4) and np.all((w >= 0) & (w <= 1 + 1e-6))
    assert np.median(w.sum(axis=1)) == pytest.approx(1.0, abs=1e-3)  # most rows are normalised
    assert m.vertex_attributes["joints"].max() < 86


def test_emitter_collider_pairs_fit(shared_data):
    """The README's fit: hair roots lie close to their mesh (median root-to-vertex distance,
    centimetres in the README, metres once loaded)."""
    from scipy.spatial import cKDTree

    for hair, mesh, median in (("tressfx/Ratboy_mohawk.tfx", "tressfx/Ratboy_body.tfxmesh", 0.59),
                               ("tressfx/sintel_hair.tfx", "heads/sintel.obj", 0.81)):
        g = mane.load(shared_data / hair)
        m = mane.load_mesh(shared_data / mesh, like=g)
        d, _ = cKDTree(m.vertices).query(g.roots)
        assert np.median(d) == pytest.approx(median * 0.01, abs=0.0002)


# what each file is, in metres with Y up (the README: Sintel's hair ~27 cm tall, Ratboy's body
# ~113 cm across its diagonal, the Lee Perry-Smith scan a head in its own units)
UPRIGHT = {"tressfx/Ratboy_mohawk.tfx": "hair", "tressfx/sintel_hair.tfx": "hair",
           "tressfx/bear_v3.tfx": "fur", "tressfx/v3_ponytail/ponytail.tfxproj": "hair",
           "heads/sintel.obj": "head", "tressfx/Ratboy_body.tfxmesh": "body", "heads/LeePerrySmith.glb": "head"}


@pytest.mark.parametrize("name", sorted(UPRIGHT))
def test_real_files_load_upright_in_metres(shared_data, name):
    """No flags: every file comes out in metres, Y up, at a human (or bear) scale."""
    import warnings

    kind = UPRIGHT[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        obj = mane.load(shared_data / name) if kind in ("hair", "fur") else mane.load_mesh(shared_data / name)
    assert obj.metadata["units"] == "m" and obj.metadata["up_axis"] == "y"
    lo, hi = obj.bbox()
    ext = hi - lo
    if kind == "head":   # a head: 0.15..0.45 m tall, taller than deep
        assert 0.15 < ext[1] < 0.45 and ext[1] > ext[2], ext
    elif kind == "body":
        assert 0.5 < ext[1] < 2.0 and ext[1] == ext.max(), ext
    elif kind == "hair":
        med = float(np.median(obj.strand_lengths()))
        assert 0.03 < med < 1.0 and 0.15 < np.linalg.norm(ext) < 2.0, (med, ext)
    else:
        assert 0.01 < float(np.median(obj.strand_lengths())) < 0.2 and np.linalg.norm(ext) < 4.0


@pytest.mark.parametrize("hair,head", [("tressfx/Ratboy_mohawk.tfx", "tressfx/Ratboy_body.tfxmesh"),
                                       ("tressfx/sintel_hair.tfx", "heads/sintel.obj")])
def test_real_heads_fit_their_grooms(shared_data, hair, head):
    """The groom's roots sit on its head, both loaded with no flags, and upright: roots above
    the head mesh's middle."""
    from mane.io.units import check_fit

    g = mane.load(shared_data / hair)
    m = mane.load_mesh(shared_data / head, like=g)
    fit = check_fit(g, m)
    assert fit["inside_fraction"] < 0.05 and fit["far_fraction"] == 0.0, fit
    lo, hi = m.bbox()
    assert np.median(g.roots[:, 1]) > (lo[1] + hi[1]) / 2


ALL_FILES = [t[0] for t in TFX] + ["tressfx/v3_ponytail/ponytail.tfxproj"] + [m[0] for m in MESHES]


@pytest.mark.parametrize("name", ALL_FILES)
def test_info_json_on_real_files(shared_data, capsys, name):
    assert main(["info", str(shared_data / name), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    if name in [m[0] for m in MESHES]:
        verts, faces = next((v, f) for n, v, f in MESHES if n == name)
        assert info["kind"] == "mesh" and info["num_vertices"] == verts and info["num_faces"] == faces
    else:
        expected = {"tressfx/Ratboy_mohawk.tfx": (2226, 32), "tressfx/sintel_hair.tfx": (228, 32),
                    "tressfx/bear_v3.tfx": (48113, 4),
                    "tressfx/v3_ponytail/ponytail.tfxproj": (4933, 16)}[name]
        assert info["num_strands"] == expected[0] and info["num_points"] == expected[0] * expected[1]
        assert info["points_per_strand"] == {"min": expected[1], "max": expected[1], "mean": expected[1]}
    assert set(info["bbox"]) == {"min", "max"}


@pytest.mark.parametrize("suffix", [".hair", ".data", ".ply", ".npz", ".usdc", ".abc", ".tfx"])
def test_real_groom_converts_exactly(shared_data, tmp_path, capsys, suffix):
    src = shared_data / "tressfx/sintel_hair.tfx"
    out = tmp_path / f"sintel{suffix}"
    assert main(["convert", str(src), str(out)]) == 0
    a, b = mane.load(src), mane.load(out)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_array_equal(a.points, b.points)


def test_sintel_scenes_are_in_metres(shared_data):
    """The Sintel scene of the examples and of ``mane bench fidelity`` read the TressFX
    centimetres as metres once (she is ~27 cm of hair; x0.01 twice made her 2.7 mm)."""
    from mane.bench.fidelity import SCENES, load_scene
    from mane.presets import sintel_scene

    groom, head = sintel_scene(shared_data)
    bench_groom, _ = load_scene(SCENES["sintel_brown"])
    for g in (groom, bench_groom):
        lo, hi = g.bbox()
        assert 0.2 < hi[1] - lo[1] < 0.4
    lo, hi = head.bbox()
    assert 0.3 < hi[1] - lo[1] < 0.6
