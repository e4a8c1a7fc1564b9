"""What a file carries beyond points: colours, widths and transparency into RenderSettings
(mane.render.file_appearance), mesh conversion and resampling in ``mane convert``, and the
progress bars' quiet rules. No GL here: the renderer's use of the settings is one
dataclasses.replace, checked on the settings it produces."""
from __future__ import annotations

import io
import warnings

import numpy as np
import pytest
import trimesh

import mane
from mane.app.cli import main
from mane.render.file_appearance import file_appearance
from test_io_helpers import cyhair_bytes
from test_io_units import N_POINTS, reference_scene, store


def test_appearance_from_the_file_arrays():
    pts, counts, colors, widths, _ = reference_scene(n=40)
    g = mane.Groom(pts, counts, colors=colors, widths=widths,
                   transparency=np.full(len(pts), 0.25, np.float32))
    a = file_appearance(g)
    np.testing.assert_allclose(a["hair_color"], colors.mean(axis=0), rtol=1e-6)   # the mean colour
    assert a["width"] == pytest.approx(8e-5, rel=1e-5)                           # the median root width
    assert a["width_tip"] == pytest.approx(3 / 8, rel=1e-5)                      # the taper
    assert a["oit_opacity"] == pytest.approx(0.75)
    assert file_appearance(mane.Groom(pts, counts)) == {}


def test_cyhair_reference_defaults_are_not_colours(tmp_path):
    """A .hair file without colour or thickness arrays and with the reference defaults (white,
    1.0) says nothing about the look; a header default colour that was set does."""
    pts, counts, *_ = reference_scene(n=40)
    f = tmp_path / "plain.hair"
    f.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert file_appearance(mane.load(f)) == {}
        f.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts, d_color=(0.8, 0.6, 0.3)))
        assert file_appearance(mane.load(f))["hair_color"] == pytest.approx((0.8, 0.6, 0.3))


def test_render_settings_switch():
    from mane.render.settings import RenderSettings

    assert RenderSettings().use_file_colors is True
    assert RenderSettings(use_file_colors=False).use_file_colors is False


def test_render_cli_file_colours_switch():
    from mane.app.cli import build_parser

    p = build_parser("render")
    assert p.parse_args(["render", "g.hair"]).file_colors is True
    assert p.parse_args(["render", "g.hair", "--no-file-colors"]).file_colors is False


def test_file_strands_per_guide():
    from mane.app.render import file_strands_per_guide

    assert file_strands_per_guide(228) == 16          # a guide-like file: multiplied fully
    assert file_strands_per_guide(10_000) == 10       # ~100,000 hairs in all
    assert file_strands_per_guide(50_000) == 2
    assert file_strands_per_guide(300_000) == 1


def test_convert_mesh_units_and_axes(tmp_path, capsys):
    """A head in millimetres, Z-up -> a GLB in metres, Y-up."""
    head = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    stored = head.copy()
    stored.vertices = store(head.vertices + [0, 0.05, 0], 0.001, "z")
    src, dst = tmp_path / "head.obj", tmp_path / "head.glb"
    stored.export(src)
    assert main(["convert", str(src), str(dst), "--units", "mm", "--up", "z"]) == 0
    assert "mesh" in capsys.readouterr().out
    back = mane.load_mesh(dst)
    np.testing.assert_allclose(back.vertices, head.vertices + [0, 0.05, 0], atol=1e-6)
    assert back.metadata["frame"]["units_source"] == "convention"   # glTF: metres, fitting
    assert main(["convert", str(src), str(tmp_path / "x.hair")]) == 2


def test_convert_points_resamples(tmp_path, capsys):
    pts, counts, colors, widths, _ = reference_scene(n=30)
    src = tmp_path / "a.npz"
    mane.save(mane.Groom(pts, counts, colors=colors, widths=widths), src)
    for suffix, n in ((".ply", 9), (".tfx", 8)):
        dst = tmp_path / f"b{suffix}"
        assert main(["convert", str(src), str(dst), "--points", str(n)]) == 0
        back = mane.load(dst)
        assert back.uniform_count == n
        np.testing.assert_allclose(back.roots, pts[::N_POINTS], atol=1e-6)
    assert main(["convert", str(src), str(tmp_path / "c.tfx"), "--points", "10"]) == 2
    assert "4, 8, 16, 32 or 64" in capsys.readouterr().err


def test_progress_is_quiet_off_a_terminal(monkeypatch):
    from mane import progress

    monkeypatch.setattr("sys.stderr", io.StringIO())          # not a terminal
    assert progress.progress([1, 2]) == [1, 2]
    bar = progress.stage("x", 3)
    bar.update()
    bar.close()

    class Tty(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr("sys.stderr", Tty())
    assert progress.enabled() and not progress.enabled(quiet=True)
    monkeypatch.setenv("MANE_QUIET", "1")
    assert not progress.enabled()
    monkeypatch.delenv("MANE_QUIET")
    bar = progress.progress(range(3), desc="t", delay=0)
    assert list(bar) == [0, 1, 2]


@pytest.mark.gpu
def test_renderer_takes_the_file_colour(gl):
    """set_strands(groom) puts the file's look in the renderer's settings and material, unless
    use_file_colors is off."""
    from mane.render import Renderer, RenderSettings

    from mane.io.units import normalize_groom

    pts, counts, colors, widths, _ = reference_scene(n=20)
    grown = mane.Groom(pts, counts, colors=colors, widths=widths)   # not from a file: scene look
    g = normalize_groom(grown, units="m", up="y")                    # as mane.load gives it
    r = Renderer(RenderSettings(size=(32, 32)), ctx=gl)
    try:
        r.set_strands(grown)
        assert r.settings.hair_color == RenderSettings().hair_color and r.file_appearance == {}
        r.set_strands(g)
        np.testing.assert_allclose(r.settings.hair_color, colors.mean(axis=0), rtol=1e-6)
        np.testing.assert_allclose(r.hair_color(), colors.mean(axis=0), rtol=1e-6)
        assert r.settings.width == pytest.approx(8e-5, rel=1e-5)
    finally:
        r.release()
    off = RenderSettings(size=(32, 32), use_file_colors=False)
    r = Renderer(off, ctx=gl)
    try:
        r.set_strands(g)
        assert r.settings.hair_color == off.hair_color and r.settings.width == off.width
    finally:
        r.release()


@pytest.mark.gpu
def test_a_file_groom_look_does_not_outlive_it(gl, tmp_path):
    """One renderer, a red file groom then a grown one: the second renders with the scene's
    settings again (the file's look belongs to its groom only)."""
    from dataclasses import replace

    from mane.render import Renderer, RenderSettings
    from mane.grooming.scene import default_scene

    groom, _ = default_scene(num_guides=8, points=6, subdivisions=2)
    red = replace(groom, colors=np.tile(np.float32([0.9, 0.1, 0.1]), (groom.num_points, 1)))
    mane.save(red, tmp_path / "red.npz")
    from_file = mane.load(tmp_path / "red.npz", units="m", up="y")
    r = Renderer(RenderSettings(size=(32, 32)), ctx=gl)
    try:
        base = r.settings
        r.set_strands(from_file)
        assert r.settings.hair_color == pytest.approx((0.9, 0.1, 0.1), abs=1e-6)
        r.set_strands(groom)
        assert r.settings == base and r.file_appearance == {}
    finally:
        r.release()
