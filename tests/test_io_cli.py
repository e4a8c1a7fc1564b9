"""``mane info`` and ``mane convert`` through ``mane.app.cli.main``."""
from __future__ import annotations

import json

import numpy as np
import pytest

import mane
from mane.app.cli import main
from test_io_helpers import sample_groom


def run_json(capsys, *argv):
    assert main(["info", *argv, "--json"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1  # exactly one JSON object on one line
    return json.loads(out)


def test_info_json_hair(tmp_path, capsys):
    g = sample_groom([3, 5, 2, 4])
    f = tmp_path / "g.ply"
    mane.save(g, f)
    info = run_json(capsys, str(f))
    assert info["kind"] == "hair" and info["num_strands"] == 4 and info["num_points"] == 14
    assert info["points_per_strand"] == {"min": 2, "max": 5, "mean": 3.5}
    np.testing.assert_allclose(info["bbox"]["min"], g.points.min(0))
    np.testing.assert_allclose(info["bbox"]["max"], g.points.max(0))
    assert "widths" in info["attributes"] and info["format"] == "strand PLY"


def test_info_table(tmp_path, capsys):
    f = tmp_path / "g.hair"
    mane.save(sample_groom(), f)
    assert main(["info", str(f)]) == 0
    out = capsys.readouterr().out
    lines = out.strip().splitlines()
    assert lines[0].startswith("file") and any(ln.startswith("strands") for ln in lines)
    col = lines[0].index(str(f))
    assert all(len(ln) > col and ln[col - 1] == " " and ln[col] != " " for ln in lines)  # aligned


def test_info_mesh_ply_and_obj(tmp_path, capsys):
    f = tmp_path / "m.obj"
    f.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    info = run_json(capsys, str(f))
    assert info["kind"] == "mesh" and info["num_vertices"] == 4 and info["num_faces"] == 2
    assert info["bbox"] == {"min": [0, 0, 0], "max": [1, 1, 0]}
    p = tmp_path / "m.ply"
    p.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                 "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                 "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    info = run_json(capsys, str(p))
    assert info["kind"] == "mesh" and info["num_faces"] == 1


@pytest.mark.parametrize("argv", [
    ["info", "missing.hair"],
    ["info", "file.xyz"],
    ["convert", "missing.hair", "out.ply"],
])
def test_cli_errors_have_no_traceback(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    if argv[1] == "file.xyz":
        (tmp_path / "file.xyz").write_text("x")
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err


def test_cli_corrupt_file(tmp_path, capsys):
    f = tmp_path / "bad.hair"
    f.write_bytes(b"HAIR" + b"\xff" * 200)
    assert main(["info", str(f)]) == 2
    err = capsys.readouterr().err
    assert str(f) in err and "Traceback" not in err


def test_convert_up_and_scale(tmp_path, capsys):
    g = sample_groom()
    src, dst = tmp_path / "in.npz", tmp_path / "out.ply"
    mane.save(g, src)
    assert main(["convert", str(src), str(dst), "--up", "z", "--scale", "0.5"]) == 0
    out = capsys.readouterr().out.strip()
    assert out.count("\n") == 0 and "4 strands" in out and str(dst) in out
    back = mane.load(dst)
    z_to_y = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float)
    np.testing.assert_allclose(back.points, (g.points @ z_to_y.T) * 0.5, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(back.widths, g.widths * 0.5, rtol=1e-6)


def test_convert_exact_round_trip(tmp_path, capsys):
    g = sample_groom()
    a, b, c = tmp_path / "a.npz", tmp_path / "b.hair", tmp_path / "c.npz"
    mane.save(g, a)
    assert main(["convert", str(a), str(b)]) == 0
    assert main(["convert", str(b), str(c)]) == 0
    assert mane.load(c).equals(g)


def test_convert_bad_scale(tmp_path, capsys):
    a = tmp_path / "a.npz"
    mane.save(sample_groom(), a)
    assert main(["convert", str(a), str(tmp_path / "b.ply"), "--scale", "-1"]) == 2
    assert "scale" in capsys.readouterr().err
    assert not (tmp_path / "b.ply").exists()
