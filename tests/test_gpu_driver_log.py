"""The driver's debug messages (gpu.driver_log) and what they showed: GL errors that mane's own
use of framebuffers caused. On llvmpipe Mesa reports errors and performance notes; NVIDIA's
buffer-placement messages are parsed from their text (as the H200's driver wrote them)."""
from __future__ import annotations

import ctypes
import json

import pytest

from mane.gpu.driver_log import DriverLog
from mane.gpu.entry_points import gl_entry

pytestmark = pytest.mark.gpu

NVIDIA_MOVE = ("Buffer performance warning: Buffer object 1 (bound to GL_ARRAY_BUFFER_ARB, and "
               "GL_SHADER_STORAGE_BUFFER (0), usage hint is GL_STATIC_DRAW) is being copied/moved from VIDEO "
               "memory to DMA CACHED memory.")


def _bad_call():
    """A GL error on purpose: binding a framebuffer name that was never generated."""
    gl_entry("glBindFramebuffer", None, ctypes.c_uint, ctypes.c_uint)(0x8D40, 987654)


def test_records_an_error_while_on_and_nothing_after(gl):
    log = DriverLog(gl)
    assert log.available, log.reason
    with log:
        _bad_call()
        _bad_call()
    s = log.summary()
    assert s["messages"] == 2 and s["errors"] == 2
    (kind,) = s["kinds"]
    assert kind["type"] == "error" and kind["source"] == "api" and kind["count"] == 2
    assert "Framebuffer" in kind["text"]   # Mesa names glBindFramebuffer, NVIDIA "Framebuffer name must be generated"
    _bad_call()                       # the callback is gone: nothing more is recorded
    assert log.summary()["messages"] == 2
    gl.finish()
    json.dumps(s)                     # the bench puts it in its JSON


def test_messages_group_by_kind_with_numbers_blanked_and_moves_are_parsed(gl):
    log = DriverLog(gl)
    for n in (1, 7, 12):
        log.record(0x8246, 0x8250, 131186, 0x9147, NVIDIA_MOVE.replace("object 1 ", f"object {n} "))
    log.record(0x8246, 0x8251, 131185, 0x826B, "Buffer detailed info: Buffer object 3 (bound to "
               "GL_SHADER_STORAGE_BUFFER (1), usage hint is GL_STATIC_DRAW) will use VIDEO memory as the "
               "source for buffer object operations.")
    s = log.summary()
    assert s["messages"] == 4 and len(s["kinds"]) == 2 and s["kinds"][0]["count"] == 3
    assert s["kinds"][0]["type"] == "performance" and s["kinds"][0]["severity"] == "medium"
    assert s["buffer_moves"] == [{"from": "VIDEO", "to": "DMA CACHED", "count": 3,
                                  "text": NVIDIA_MOVE}]
    assert "3 buffer moves" in log.text()


def test_kinds_are_bounded(gl, monkeypatch):
    import mane.gpu.driver_log as dl

    monkeypatch.setattr(dl, "MAX_KINDS", 3)
    log = DriverLog(gl)
    for word in ("alpha", "beta", "gamma", "delta", "epsilon"):
        log.record(0x8246, 0x824C, 1, 0x9146, f"error {word}")
    s = log.summary()
    assert len(s["kinds"]) == 3 and s["messages"] == 5 and s["dropped"] == 2


def test_renderers_and_simulators_made_and_released_cause_no_gl_errors(gl):
    """moderngl binds the last framebuffer used again whenever it makes one; a released one was a
    GL_INVALID_OPERATION every time (the headless context now has a framebuffer of its own to
    return to, and the capture helper returns to it). Two renderers and simulators in turn, each
    rendered, read, captured and released, then a third made: no error."""
    from mane.bench import sim_bench
    from mane.render import Renderer, RenderSettings
    from mane.render.capture import capture_segments
    from mane.sim import Simulator

    with DriverLog(gl) as log:
        for rasterizer, shadows in (("compute", "deep_opacity"), ("hardware", "shadow_map")):
            sim = Simulator(sim_bench.scalp_groom(60, 8), ctx=gl)
            r = Renderer(RenderSettings(size=(48, 32), rasterizer=rasterizer, shadows=shadows), ctx=gl, profile=False)
            r.set_strands(sim)
            r.set_head(sim_bench.head_mesh())
            cam = r.default_camera()
            sim.step()
            r.strands_changed()
            capture_segments(r)   # before the first frame makes the render targets
            r.render(cam)
            r.read_image()
            r.release()
            sim.release()
        Renderer(RenderSettings(size=(48, 32)), ctx=gl, profile=False).release()
    s = log.summary()
    assert s["errors"] == 0, [k for k in s["kinds"] if k["type"] == "error"]


def test_bench_cli_adds_the_log_to_its_json(tmp_path, capsys):
    from mane.app import cli

    out = tmp_path / "limits.json"
    assert cli.main(["bench", "limits", "--quick", "--quiet", "--driver-log", "--section", "raster",
                     "--out", str(out)]) == 0
    log = json.loads(out.read_text())["meta"]["driver_log"]
    assert log["available"] and log["errors"] == 0 and "not comparable" in log["note"]
    assert "driver messages:" in capsys.readouterr().out


def test_limits_refuses_an_unknown_section(capsys):
    from mane.app import cli

    assert cli.main(["bench", "limits", "--quick", "--section", "copy"]) == 2
    assert "unknown limits section 'copy'; sections: dram, raster, atomics" in capsys.readouterr().err


def test_bench_cli_refuses_the_log_for_folder_targets(capsys):
    from mane.app import cli

    assert cli.main(["bench", "quality", "--quick", "--driver-log"]) == 2
    assert "--driver-log is not available for quality" in capsys.readouterr().err
