"""``mane grow``: writes a loadable groom and prints a summary line."""
from __future__ import annotations

import numpy as np
import pytest

from mane.app.cli import main


def test_grow_writes_npz(tmp_path, capsys):
    pytest.importorskip("mane.io.native_npz")
    import mane

    out = tmp_path / "curly.npz"
    rc = main(["grow", "--style", "curly", "--strands", "300", "--points", "12", "--seed", "4",
               "--curl-radius", "0.008", "--curl-pitch", "0.03", "--length", "0.2", "--out", str(out)])
    assert rc == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith("grew 300 strands x 12 points (curly)") and str(out) in line
    g = mane.load(out)
    assert g.num_strands == 300 and g.uniform_count == 12
    from mane.grooming import grow

    direct = grow(None, 300, "curly", 12, 4, curl_radius=0.008, curl_pitch=0.03, length=0.2)
    np.testing.assert_allclose(g.points, direct.points, atol=1e-7)


def test_grow_blue_noise_on_a_mesh_file(tmp_path, capsys):
    pytest.importorskip("mane.io.native_npz")
    import trimesh

    import mane

    mesh_path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=2, radius=0.1).export(mesh_path)
    out = tmp_path / "ball.npz"
    assert main(["grow", "--mesh", str(mesh_path), "--strands", "200", "--points", "6",
                 "--blue-noise", "--out", str(out)]) == 0
    assert "ball.obj" in capsys.readouterr().out
    assert mane.load(out).num_strands == 200


def test_grow_bad_arguments(tmp_path, capsys):
    assert main(["grow", "--strands", "0", "--out", str(tmp_path / "x.npz")]) == 2
    assert "--strands must be positive" in capsys.readouterr().err
    assert main(["grow", "--points", "1", "--out", str(tmp_path / "x.npz")]) == 2
    assert main(["grow", "--strands", "5", "--out", str(tmp_path / "x.unknown")]) == 2
    assert "cannot write .unknown" in capsys.readouterr().err


def test_grow_on_a_millimetre_z_up_mesh_with_head_options(tmp_path, capsys):
    """--head-units/--head-up apply to --mesh: a 200 mm ball stored Z-up grows hair on a 0.2 m
    ball, Y up (the roots lie on its surface, 0.1 m from its centre)."""
    import trimesh

    import mane

    ball = trimesh.creation.icosphere(subdivisions=2, radius=100.0)
    ball.apply_translation((0.0, 0.0, 500.0))            # 0.5 m up along Z, in mm
    mesh_path = tmp_path / "ball_mm.obj"
    ball.export(mesh_path)
    out = tmp_path / "ball.npz"
    assert main(["grow", "--mesh", str(mesh_path), "--head-units", "mm", "--head-up", "z", "--strands", "100",
                 "--points", "4", "--out", str(out)]) == 0
    roots = mane.load(out, units="m", up="y").roots.astype(np.float64)
    r = np.linalg.norm(roots - (0.0, 0.5, 0.0), axis=1)
    np.testing.assert_allclose(r, 0.1, atol=0.004)
