"""``mane demo`` end to end on the software renderer: every file it promises, and a video that decodes."""
import json

import numpy as np
import pytest

from mane import load
from mane.app.cli import main


@pytest.mark.slow
def test_demo_writes_video_sheet_animation_and_timings(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--seconds", "0.25", "--quality", "software", "--headless",
                 "--hair", "blond"]) == 0
    text = capsys.readouterr().out
    assert "points identical" in text and " NO" not in text
    assert "frames per second simulated and rendered at 960x540" in text
    import imageio.v2 as imageio

    reader = imageio.get_reader(str(out / "demo.mp4"))
    video = [f for f in reader]
    reader.close()
    timings = json.loads((out / "demo_timings.json").read_text())
    assert len(video) == timings["frames"] == 6  # 0.25 s at 24 fps
    assert video[0].shape == (540, 960, 3)   # SOFTWARE: 960x540 at 15+ fps
    assert video[0].std() > 5  # not a blank frame
    sheet = imageio.imread(out / "demo_contact_sheet.png")
    assert sheet.shape[0] >= 540 and sheet.shape[1] == 3 * 960
    anim = load(out / "demo_simulation.usda")
    assert anim.metadata["usd"]["num_time_samples"] == 6
    assert np.all(np.isfinite(anim.points))
    assert timings["invariants"]["nan_recoveries"] == 0


def test_demo_hair_preset_reaches_the_renderer():
    import dataclasses

    from mane.app.demo import GPU, SOFTWARE
    from mane.render.shading import PRESETS

    s = dataclasses.replace(SOFTWARE, hair="auburn").render_settings()
    assert s.shading_options["melanin"] == PRESETS["auburn"] and s.hair_color is None
    g = GPU.render_settings()
    assert g.shading == "chiang" and g.shading_options["melanin"] == PRESETS["brown"]
    assert g.shading_options["multiple_scattering"] == "auto"
    assert main(["demo", "--hair", "green", "--headless", "--out", "/nonexistent/never"]) == 2


def test_the_software_preset_leaves_the_skin_bounce_out():
    """The skin's bounce has no occlusion by the hair without deep opacity maps (the software
    preset casts a shadow map): the CPU rasteriser's preset turns it off, the GPU's keeps the
    renderer's default."""
    from mane.app.demo import GPU, SOFTWARE
    from mane.render import RenderSettings

    assert SOFTWARE.render_settings().skin_bounce == 0.0
    assert GPU.render_settings().skin_bounce == RenderSettings().skin_bounce > 0.0


def test_the_software_preset_draws_with_the_raster_units():
    """On a CPU rasteriser "auto" picks the compute rasteriser (the default frame 25x faster
    there), but the software preset's light frames (lines, Kajiya-Kay, a shadow map) are faster by
    the raster units (37.6 against 63.1 ms at the demo's size): it names them; the GPU's follows
    "auto"."""
    from mane.app.demo import GPU, SOFTWARE
    from mane.render.passes.hair_compute import wants_compute

    assert SOFTWARE.render_settings().rasterizer == "hardware"
    assert not wants_compute(SOFTWARE.render_settings(), "llvmpipe (LLVM 15.0.6, 256 bits)")
    assert GPU.render_settings().rasterizer == "auto"
    assert wants_compute(GPU.render_settings(), "llvmpipe (LLVM 15.0.6, 256 bits)")
