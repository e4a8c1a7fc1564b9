"""Capabilities.query on the session context (Mesa llvmpipe on CPU machines)."""
from __future__ import annotations

import pytest

from mane.errors import GLFeatureError
from mane.gpu.capabilities import (EXTENSIONS_THAT_MATTER, FEATURES, LIMITS, Capabilities, _features,
                                   get_capabilities, gl_function)

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def caps(gl):
    return Capabilities.query(gl)


@pytest.fixture(scope="module")
def llvmpipe(caps):
    if "llvmpipe" not in caps.renderer:
        pytest.skip(f"not on llvmpipe ({caps.renderer})")
    return caps


def test_basic_fields(caps, gl):
    assert caps.version_code >= 430 and caps.version_code == gl.version_code
    assert caps.renderer and caps.vendor and caps.version
    assert caps.glsl_version[:1].isdigit()
    assert isinstance(caps.extensions, frozenset) and caps.extensions


def test_every_limit_is_read_and_positive(caps):
    assert set(caps.limits) == set(LIMITS)
    for key, value in caps.limits.items():
        values = value if isinstance(value, list) else [value]
        assert values and all(isinstance(v, int) and v > 0 for v in values), (key, value)
    assert len(caps.limits["max_compute_work_group_count"]) == 3


def test_limits_not_in_ctx_info_come_through_ctypes(caps):
    # moderngl's ctx.info lacks these: they must have come from glGetIntegerv via ctypes.
    assert caps.limits["max_tess_gen_level"] >= 64       # GL 4.x minimum
    assert caps.limits["max_patch_vertices"] >= 32
    assert caps.limits["max_compute_shared_memory_size"] >= 32768


def test_feature_table_is_complete(caps):
    assert tuple(caps.features) == FEATURES
    for f in caps.features.values():
        assert isinstance(f.available, bool) and f.reason
        if not f.available:
            assert f.hint
    assert caps.available("compute_simulation")
    caps.require("compute_simulation")


def test_llvmpipe(llvmpipe):
    caps = llvmpipe
    assert caps.is_software
    assert caps.version_code >= 430
    assert not caps.available("fragment_interlock")
    assert not caps.available("nv_mesh_shader")
    assert not caps.available("timer_queries")  # unreliable there: the profiler uses the CPU
    assert caps.available("tessellated_strands") and caps.available("geometry_ribbons")
    assert caps.memory.source == "system RAM (software renderer)"
    assert caps.memory.total and caps.memory.available


def test_require_says_what_is_missing_and_what_to_do(llvmpipe):
    with pytest.raises(GLFeatureError) as info:
        llvmpipe.require("fragment_interlock")
    message = str(info.value)
    assert "GL_ARB_fragment_shader_interlock" in message and "llvmpipe" in message
    assert "What to do:" in message
    with pytest.raises(GLFeatureError, match="unknown feature"):
        llvmpipe.require("warp_drive")


def test_as_dict_is_json_ready(caps):
    import json

    d = json.loads(json.dumps(caps.as_dict()))
    assert set(d["extensions"]) == set(EXTENSIONS_THAT_MATTER)
    assert d["features"]["compute_simulation"]["available"] is True


def test_cached_per_context(gl):
    assert get_capabilities(gl) is get_capabilities(gl)


def test_query_leaves_the_context_current(gl):
    Capabilities.query(gl)
    shader = gl.compute_shader("#version 430\nlayout(local_size_x = 1) in;\nvoid main() {}\n")
    shader.release()


def test_missing_entry_point_is_none(gl, monkeypatch):
    # glvnd hands out a no-op stub for any gl* name, so "no address" is rare; when it
    # happens (no loader at all) the function is None and every reading is None.
    import ctypes

    from mane.gpu import capabilities as capmod

    monkeypatch.setattr(capmod, "_load_address", lambda ctx, name: 0)
    monkeypatch.setattr(capmod, "_procs", capmod.weakref.WeakKeyDictionary())
    assert gl_function(gl, "glGetIntegerv", None, ctypes.c_uint, ctypes.c_void_p) is None
    caps = Capabilities.query(gl)
    assert caps.limits["max_tess_gen_level"] is None          # only ctypes could read it
    assert caps.limits["max_texture_size"] > 0                # ctx.info still had it
    assert caps.glsl_version  # falls back to the GL version


# -------------------------------------------------------------- features from made-up drivers

H100_EXTS = frozenset({"GL_ARB_gpu_shader_int64", "GL_NV_shader_atomic_int64", "GL_NV_fragment_shader_interlock",
                       "GL_ARB_fragment_shader_interlock", "GL_NV_mesh_shader", "GL_ARB_timer_query",
                       "GL_NVX_gpu_memory_info"})
LIMITS_OK = {"max_compute_work_group_invocations": 1024, "max_shader_storage_buffer_bindings": 96,
             "max_tess_gen_level": 64, "max_patch_vertices": 32, "max_geometry_output_vertices": 1024,
             "max_fragment_shader_storage_blocks": 16, "max_samples": 32, "max_color_attachments": 8}


def test_nvidia_like_driver_has_everything():
    table = _features(460, H100_EXTS, LIMITS_OK, software=False)
    assert all(f.available for f in table.values()), {n: f.reason for n, f in table.items() if not f.available}


def test_opengl_41_lacks_compute():
    table = _features(410, frozenset({"GL_ARB_timer_query"}), dict(LIMITS_OK, max_compute_work_group_invocations=None),
                      software=False)
    assert not table["compute_simulation"].available
    assert "4.1" in table["compute_simulation"].reason and "4.3" in table["compute_simulation"].reason
    assert table["tessellated_strands"].available


def test_int64_without_atomics_is_not_enough():
    table = _features(450, frozenset({"GL_ARB_gpu_shader_int64"}), LIMITS_OK, software=False)
    assert not table["kbuffer_int64"].available
    assert "GL_NV_shader_atomic_int64" in table["kbuffer_int64"].reason
