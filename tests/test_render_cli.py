"""``mane render``: PNG and MP4 output, the stats JSON, --simulate reading the simulator's buffer."""
from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from mane.app.cli import main
from mane.groom import Groom

pytestmark = pytest.mark.gpu


@pytest.fixture
def groom_file(tmp_path):
    from mane.io import save

    t = np.linspace(0, 1, 8)
    g = Groom.from_strands([np.c_[0.03 * np.cos(a) + 0.05 * t * np.cos(a), 0.1 - 0.25 * t, 0.03 * np.sin(a) + 0 * t]
                            for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)])
    path = tmp_path / "g.npz"
    save(g, path)
    return path


def test_png_and_stats(groom_file, tmp_path, capsys):
    out, stats = tmp_path / "a.png", tmp_path / "s.json"
    rc = main(["render", str(groom_file), "--out", str(out), "--size", "96x72", "--stats", str(stats),
               "--strands-per-guide", "5", "--shadows", "shadow_map", "--aa", "ssaa2",
               "--light", "dir:0,1,0.5:2", "--light", "point:0.3,0.3,0.5:0.5:1,0.8,0.6",
               "--camera", "30,10"])
    assert rc == 0
    from PIL import Image

    img = np.asarray(Image.open(out))
    assert img.shape == (72, 96, 3) and img.std() > 1
    s = json.loads(stats.read_text())
    assert {"passes", "frames", "size", "renderer", "rendered_strands", "rendered_segments"} <= set(s)
    # a still picture: its first frame and the 16 moved ones its mean averages (RenderSettings.accumulate)
    assert s["frames"] == 17 and s["still_frames"] == 16 and s["size"] == [96, 72] and s["rendered_strands"] == 12 * 5
    assert {"shadow_map", "resolve", "accumulate"} <= set(s["passes"])
    assert ("hair" in s["passes"]) != ("hair_compute" in s["passes"])   # raster units or compute (H100/H200)
    assert all(v >= 0 for v in s["passes"].values())


def test_every_light_casts_shadows_unless_told(groom_file, tmp_path):
    """A picture under several lights shadows each of them by default (--shadow-lights: the first
    n only)."""
    for extra, want in (([], True), (["--shadow-lights", "1"], False)):
        stats = tmp_path / "s.json"
        assert main(["render", str(groom_file), "--out", str(tmp_path / "a.png"), "--size", "48x36", "--aa", "none",
                     "--shadows", "shadow_map", "--set", "accumulate=1", "--stats", str(stats),
                     "--light", "dir:0,1,0.5:2", "--light", "dir:1,0.2,0.3:1", *extra]) == 0
        assert ("extra_shadows" in json.loads(stats.read_text())["passes"]) == want, extra


def _ffmpeg():
    """imageio-ffmpeg is a mane dependency; an environment without it skips the MP4 tests
    (test_mp4_without_ffmpeg_is_a_clear_error covers that case)."""
    return pytest.importorskip("imageio_ffmpeg", reason="imageio-ffmpeg (a mane dependency) is not installed")


def test_turntable_mp4(groom_file, tmp_path):
    imageio_ffmpeg = _ffmpeg()
    out = tmp_path / "t.mp4"
    rc = main(["render", str(groom_file), "--out", str(out), "--size", "64x48", "--frames", "3", "--aa", "none"])
    assert rc == 0
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    frames = [np.frombuffer(f, np.uint8).reshape(48, 64, 3) for f in reader]
    assert meta["size"] == (64, 48) and len(frames) == 3
    assert np.abs(frames[0].astype(int) - frames[1].astype(int)).mean() > 0.1   # the camera turned


def test_simulate_reads_the_simulator(groom_file, tmp_path):
    _ffmpeg()
    out, stats = tmp_path / "s.mp4", tmp_path / "s.json"
    rc = main(["render", str(groom_file), "--out", str(out), "--size", "64x48", "--frames", "2",
               "--simulate", "--stats", str(stats), "--aa", "none", "--shadows", "none"])
    assert rc == 0
    s = json.loads(stats.read_text())
    assert s["frames"] == 2 and "simulate" in s["passes"]


def test_mp4_without_ffmpeg_is_a_clear_error(groom_file, tmp_path, capsys, monkeypatch):
    """Without imageio-ffmpeg imageio would hand the .mp4 to its TIFF writer (TypeError on
    fps); mane says what is missing instead."""
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)     # import imageio_ffmpeg fails
    out = tmp_path / "t.mp4"
    rc = main(["render", str(groom_file), "--out", str(out), "--size", "64x48", "--frames", "2", "--aa", "none"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "imageio-ffmpeg" in err and "pip install" in err
    from mane.errors import ManeError
    from mane.io.video import mp4_writer

    with pytest.raises(ManeError, match="imageio-ffmpeg"):
        mp4_writer(out, 24)


def test_bad_arguments(groom_file, tmp_path, capsys):
    assert main(["render", str(groom_file), "--out", str(tmp_path / "a.png"), "--frames", "3"]) == 2
    assert main(["render", str(groom_file), "--out", str(tmp_path / "a.gif")]) == 2
    assert main(["render", str(groom_file), "--out", str(tmp_path / "a.png"), "--light", "sun:1"]) == 2
    assert "error" in capsys.readouterr().err


def test_hair_presets_melanin_and_multiple_scattering(groom_file, tmp_path, capsys):
    """--hair PRESET / --melanin EU,PHEO drive the colour (blond renders lighter and redder than
    blue where black is near the background's darkness), --multiple-scattering picks the term;
    bad values are one-line errors."""
    import argparse

    from PIL import Image

    from mane.app.render import hair_options

    imgs = {}
    for name, extra in (("black", ["--hair", "black"]), ("blond", ["--melanin", "0.3,0.1"])):
        out = tmp_path / f"{name}.png"
        assert main(["render", str(groom_file), "--out", str(out), "--size", "64x48", "--aa", "none",
                     "--shadows", "none", "--head", "none", "--turntable", "0", "--set", "accumulate=1",
                     *extra]) == 0   # one frame: thin strands whole, not spread by the still's jitter
        imgs[name] = np.asarray(Image.open(out), np.float64)[..., :3]
    hair = np.abs(imgs["blond"] - imgs["black"]).max(-1) > 8
    assert hair.sum() > 20
    blond, black = imgs["blond"][hair].mean(0), imgs["black"][hair].mean(0)
    assert blond.sum() > 1.5 * black.sum() and blond[0] > blond[2], (blond, black)
    ns = argparse.Namespace(hair="dark brown", melanin=None, multiple_scattering="none", color=None)
    assert hair_options(ns) == {"melanin": (3.0, 0.3), "multiple_scattering": "none"}
    for bad in (["--hair", "green"], ["--melanin", "1.3"], ["--melanin=-1,0"], ["--multiple-scattering", "zinke"],
                ["--hair", "blond", "--melanin", "1,0"], ["--hair", "blond", "--color", "0.3,0.2,0.1"]):
        assert main(["render", str(groom_file), "--out", str(tmp_path / "x.png"), "--size", "32x24", *bad]) == 2
        err = capsys.readouterr().err
        assert "error" in err and len(err.strip().splitlines()) == 1, err
