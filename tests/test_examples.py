"""Every script in examples/ runs headless with small settings and writes what it says."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
pytestmark = pytest.mark.gpu


def run_example(name: str, *args: str, cwd: Path) -> str:
    r = subprocess.run([sys.executable, str(EXAMPLES / name), *args], cwd=cwd, capture_output=True,
                       text=True, timeout=400)
    assert r.returncode == 0, f"{name} failed:\n{r.stdout}\n{r.stderr}"
    return r.stdout


def test_examples_folder_has_the_four_scripts():
    names = {p.name for p in EXAMPLES.glob("*.py")}
    assert {"load_and_render.py", "simulate.py", "turntable.py", "export_usd.py"} <= names


@pytest.mark.slow
def test_load_and_render(tmp_path):
    from PIL import Image

    out = run_example("load_and_render.py", "--size", "160x120", "--out", "g.png", cwd=tmp_path)
    assert "wrote" in out
    img = Image.open(tmp_path / "g.png")
    assert img.size == (160, 120)


@pytest.mark.slow
def test_simulate(tmp_path):
    out = run_example("simulate.py", "--seconds", "0.2", "--fps", "20", cwd=tmp_path)
    assert "root error" in out and "inside the sphere" in out


@pytest.mark.slow
def test_turntable(tmp_path):
    import imageio.v2 as imageio

    run_example("turntable.py", "--frames", "4", "--size", "160x96", "--out", "t.mp4", cwd=tmp_path)
    reader = imageio.get_reader(str(tmp_path / "t.mp4"))
    frames = [f for f in reader]
    reader.close()
    assert len(frames) == 4 and frames[0].shape == (96, 160, 3)


@pytest.mark.slow
def test_export_usd(tmp_path):
    import mane

    out = run_example("export_usd.py", "--frames", "3", "--out", "a.usda", cwd=tmp_path)
    assert "3 time samples" in out
    assert mane.load(tmp_path / "a.usda").metadata["usd"]["num_time_samples"] == 3


@pytest.mark.slow
def test_sintel(tmp_path, shared_data):
    from PIL import Image

    out = run_example("sintel.py", "--size", "96x96", "--strands-per-guide", "2", "--out", "s.png",
                      "--data", str(shared_data), cwd=tmp_path)
    assert "Blender Foundation" in out and "228 guides x 2 strands" in out
    img = np.asarray(Image.open(tmp_path / "s.png"))
    assert img.shape == (96, 3 * 96, 3)
    assert img.std() > 5  # three views with something in them
