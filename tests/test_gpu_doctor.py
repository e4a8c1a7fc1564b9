"""``mane doctor``: the report, its JSON form, and a machine without OpenGL 4.3."""
from __future__ import annotations

import json

import pytest

from mane.app import doctor
from mane.app.cli import main
from mane.errors import GLFeatureError
from mane.gpu import context


@pytest.mark.gpu
def test_json_report(gl, capsys):
    assert main(["doctor", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    for key in ("renderer", "vendor", "version", "glsl_version", "software", "extensions", "limits",
                "memory", "features"):
        assert key in report, key
    assert isinstance(report["software"], bool)
    assert all(isinstance(v, bool) for v in report["extensions"].values())
    assert report["limits"]["max_tess_gen_level"] > 0
    for name, f in report["features"].items():
        assert set(f) >= {"available", "reason"}, name
    assert report["selftest"]["ok"] is True
    assert report["ok"] is True


@pytest.mark.gpu
def test_human_report(gl, capsys):
    assert main(["doctor", "--no-selftest"]) == 0
    out = capsys.readouterr().out
    assert "renderer" in out and gl.info["GL_RENDERER"] in out
    assert "fragment shader interlock" in out and "max_tess_gen_level" in out
    assert "self-test" not in out
    # the feature table is aligned: "yes"/"NO" start in the same column on every row
    rows = out.split("\nfeatures\n", 1)[1].splitlines()[1:11]
    columns = {r.index(" yes ") if " yes " in r else r.index(" NO ") for r in rows}
    assert len(columns) == 1, rows


@pytest.fixture
def no_gl(monkeypatch):
    """Context creation fails as it does without libEGL or with an OpenGL 4.1 driver."""
    import moderngl

    def fail(*args, **kwargs):
        raise Exception("eglGetDisplay failed (no libEGL)")

    monkeypatch.setattr(context, "_headless", None)
    monkeypatch.setattr(moderngl, "create_context", fail)
    monkeypatch.setattr(moderngl, "get_context", fail)


def test_without_opengl_it_explains_and_exits_nonzero(no_gl, capsys):
    assert main(["doctor"]) == 1
    err = capsys.readouterr().err
    assert "no usable OpenGL 4.3 context" in err
    assert "eglGetDisplay failed" in err
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in err
    assert "NVIDIA driver" in err and "macOS" in err


def test_without_opengl_json(no_gl, capsys):
    assert main(["doctor", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] is False and report["renderer"] is None
    assert report["missing"] and any("libegl1" in f for f in report["fix"])


def test_too_old_opengl(monkeypatch, capsys):
    def too_old(require=430):
        raise GLFeatureError("OpenGL 4.1 Metal is too old. " + context.HOW_TO_GET_GL)

    monkeypatch.setattr(context, "get_context", too_old)
    assert main(["doctor"]) == 1
    assert "too old" in capsys.readouterr().err


def test_macos_diagnosis(monkeypatch):
    monkeypatch.setattr(doctor.platform, "system", lambda: "Darwin")
    diag = doctor.diagnose_failure(Exception("no EGL"))
    assert any("4.1" in m for m in diag["missing"])
    assert any("cannot run" in f for f in diag["fix"])


def test_missing_libegl_diagnosis(monkeypatch):
    monkeypatch.setattr(doctor.platform, "system", lambda: "Linux")
    monkeypatch.setattr(doctor.ctypes.util, "find_library", lambda name: None)
    diag = doctor.diagnose_failure(Exception("cannot load libEGL.so.1"))
    assert any("libEGL" in m for m in diag["missing"])
