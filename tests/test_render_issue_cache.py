"""What the renderer keeps to issue a frame with less CPU work (issue 14, item 4): uniform
plans per (program, values dict) skipping a value by identity, programs kept per pass
(ProgramMemo), a pass's uniforms and the expansion key kept while their inputs are the same
objects, and the material's derived values kept per (frozen) ShadingSettings. None of it may
show: a frame drawn after a change equals a fresh renderer's frame."""
from __future__ import annotations

import struct
from dataclasses import replace

import numpy as np
import pytest

from mane.gpu import glsl
from mane.gpu.uniforms import forget_uniforms, write_uniform
from mane.groom import Groom
from mane.render import Renderer
from mane.render.passes.base import has_uniform, set_uniforms
from mane.render.shading import ShadingSettings
from mane.render.shading.melanin import PRESETS, melanin_to_sigma_a

from test_render_frame_cache import CAM, CAM2, LIGHTS, FakeUniform, ball, base_settings, fan, fresh


class FakeProgram:
    """A moderngl program as set_uniforms sees it: get(name, default) and an instance __dict__."""

    def __init__(self, **members):
        self._members = members

    def get(self, name, default):
        return self._members.get(name, default)


def test_set_uniforms_writes_each_value_once_and_skips_absent_names():
    a, v = FakeUniform("f"), FakeUniform("3f", dimension=3)
    prog = FakeProgram(u_a=a, u_v=v)
    values = {"u_a": 0.5, "u_v": (1.0, 2.0, 3.0), "u_gone": 7}
    set_uniforms(prog, values)
    set_uniforms(prog, values)
    assert a.written == [struct.pack("f", 0.5)] and v.written == [struct.pack("3f", 1.0, 2.0, 3.0)]
    assert has_uniform(prog, "u_a") and not has_uniform(prog, "u_gone")


def test_set_uniforms_writes_again_after_another_writer():
    """The identity skip holds only while the uniform's last write was this dict's value."""
    a = FakeUniform("f")
    prog = FakeProgram(u_a=a)
    values = {"u_a": 0.5}
    set_uniforms(prog, values)
    write_uniform(a, 0.25)           # another pass (or renderer) sharing the program
    set_uniforms(prog, values)
    assert [struct.unpack("f", w)[0] for w in a.written] == [0.5, 0.25, 0.5]
    forget_uniforms(prog)            # a direct write elsewhere: remembered values dropped
    set_uniforms(prog, values)
    assert len(a.written) == 4
    other = {"u_a": 0.75}            # another dict of values: written
    set_uniforms(prog, other)
    assert struct.unpack("f", a.written[-1])[0] == 0.75


def test_a_new_dict_each_frame_looks_its_names_up_once_and_writes_what_changed():
    """A moving camera's View makes a new dict of the same names every frame: the program's
    uniforms are looked up once for those names, and only the values that changed are written
    (a name the program lacks stays skipped); more dicts than MAX_PLANS change nothing."""
    from mane.gpu import uniforms

    class Counting(FakeProgram):
        looked = 0

        def get(self, name, default):
            Counting.looked += 1
            return super().get(name, default)

    a, v = FakeUniform("f"), FakeUniform("3f", dimension=3)
    prog = Counting(u_a=a, u_v=v)
    for i in range(uniforms.MAX_PLANS + 10):
        set_uniforms(prog, {"u_a": 0.5, "u_v": (float(i), 0.0, 0.0), "u_gone": i})
    assert Counting.looked == 3
    assert a.written == [struct.pack("f", 0.5)]
    assert v.written == [struct.pack("3f", float(i), 0.0, 0.0) for i in range(uniforms.MAX_PLANS + 10)]
    set_uniforms(prog, {"u_v": (1.0, 2.0, 3.0), "u_a": 0.25})   # other names (their order): looked up
    assert Counting.looked == 5 and struct.unpack("f", a.written[-1])[0] == 0.25


def test_set_uniforms_on_a_rebuilt_program_writes_everything():
    """A program built again (an edited shader) has new uniforms: nothing of the old one's kept."""
    values = {"u_a": 0.5}
    old = FakeProgram(u_a=FakeUniform("f"))
    set_uniforms(old, values)
    new = FakeProgram(u_a=FakeUniform("f"))
    set_uniforms(new, values)
    assert new._members["u_a"].written == [struct.pack("f", 0.5)]


def test_set_uniforms_pads_a_short_vector_list_to_the_array_length():
    u = FakeUniform("4f", array_length=3, dimension=4)
    set_uniforms(FakeProgram(u_l=u), {"u_l": [(1.0, 2.0, 3.0, 4.0)]})
    assert u.written == [struct.pack("12f", 1, 2, 3, 4, *([0.0] * 8))]


def test_program_memo_builds_again_when_deps_change_or_the_recheck_is_due(monkeypatch):
    built = []

    def build(tag):
        def make():
            built.append(tag)
            return object()
        return make

    memo = glsl.ProgramMemo()
    s1 = base_settings()
    p1 = memo.get("x", (s1,), build("a"))
    assert memo.get("x", (s1,), build("b")) is p1                       # same object
    assert memo.get("x", (replace(s1),), build("c")) is p1              # an equal copy
    p2 = memo.get("x", (replace(s1, pcf=3),), build("d"))               # other values
    assert p2 is not p1 and built == ["a", "d"]
    assert memo.get("y", (), build("e")) is not p2                      # slots are separate
    monkeypatch.setattr(glsl, "RECHECK_SECONDS", 0.0)
    memo.get("y", (), build("f"))                                       # due: asks the cache again
    assert built[-1] == "f"


def test_shading_settings_keep_derived_values_without_sharing_them():
    s = ShadingSettings(model="chiang", melanin=PRESETS["dark_brown"])
    golden = melanin_to_sigma_a(*PRESETS["dark_brown"])
    a = s.resolved_sigma_a()
    np.testing.assert_allclose(a, golden)
    a[:] = 0.0                                       # a caller's copy
    np.testing.assert_allclose(s.resolved_sigma_a(), golden)
    assert s.chiang_key() == s.chiang_key() and s.chiang_key()[0] == tuple(np.round(golden, 9))
    other = replace(s, melanin=PRESETS["blond"])    # a new object: its own values
    np.testing.assert_allclose(other.resolved_sigma_a(), melanin_to_sigma_a(*PRESETS["blond"]))
    assert other.chiang_key() != s.chiang_key()


# ---------------------------------------------------------------------------- whole frames
@pytest.mark.gpu
def test_changes_after_a_frame_reach_the_shaders(gl):
    """Each change after a frame (strand count, strands per guide, the material, the head's
    transform, the rasteriser) gives a fresh renderer's frame."""
    s1 = base_settings()
    r = Renderer(s1, ctx=gl, profile=False)
    try:
        r.set_strands(fan())
        r.set_head(ball())
        r.render_image(CAM, LIGHTS)
        # fewer guides, same settings: the expansion and the box follow
        few = fan().subset(np.arange(5))
        r.set_strands(few)
        assert np.array_equal(r.render_image(CAM, LIGHTS), fresh(s1, CAM, LIGHTS, few))
        assert r.get_pass("expand").strands == 5 * s1.strands_per_guide
        # more strands per guide and another hair colour (a new material: new uniforms, new tables)
        s2 = replace(s1, strands_per_guide=8, shading_options={"melanin": "blond"})
        r.settings = s2
        r.shading = type(r.shading)(s2.shading, s2.hair_color, s2.shading_options)
        r.set_strands(fan())
        img = r.render_image(CAM2, LIGHTS)
        assert r.get_pass("expand").strands == 9 * 8
        assert np.array_equal(img, fresh(s2, CAM2, LIGHTS))
        # the head moved (the shadow map's and the head pass's u_head_model)
        m = np.eye(4)
        m[:3, 3] = (0.01, -0.02, 0.0)
        r.set_head_transform(m)
        moved = r.render_image(CAM2, LIGHTS)
        f = Renderer(s2, ctx=gl, profile=False)
        try:
            f.set_strands(fan())
            f.set_head(ball())
            f.set_head_transform(m)
            assert np.array_equal(moved, f.render_image(CAM2, LIGHTS))
        finally:
            f.release()
        # the rasteriser switched after frames (compute_raster is kept per settings object)
        s3 = replace(s2, rasterizer="hardware")
        r.settings = s3
        r.set_head_transform(np.eye(4))
        assert not r.compute_raster
        assert np.array_equal(r.render_image(CAM2, LIGHTS), fresh(s3, CAM2, LIGHTS))
    finally:
        r.release()


@pytest.mark.gpu
def test_another_interpolation_after_a_frame_expands_with_its_kernel(gl):
    """The expansion's kernel is kept per (interpolation, mode, LOD): a switch after frames
    gives a fresh renderer's frame, and switching back the first frame again."""
    t = np.linspace(0, 1, 8)
    wavy = Groom.from_strands([np.c_[0.08 * np.cos(a) * t + 0.03 * np.sin(9 * t), 0.15 - 0.3 * t,
                                     0.08 * np.sin(a) * t + 0.03] for a in np.linspace(0, np.pi, 9)])
    s1 = base_settings(interpolation="catmull_rom")
    r = Renderer(s1, ctx=gl, profile=False)
    try:
        r.set_strands(wavy)
        r.set_head(ball())
        first = r.render_image(CAM, LIGHTS)
        s2 = replace(s1, interpolation="bspline")
        r.settings = s2
        other = r.render_image(CAM, LIGHTS)
        assert not np.array_equal(other, first)
        assert np.array_equal(other, fresh(s2, CAM, LIGHTS, wavy))
        r.settings = s1
        assert np.array_equal(r.render_image(CAM, LIGHTS), first)
    finally:
        r.release()


@pytest.mark.gpu
def test_rebuilt_programs_get_every_uniform(gl, monkeypatch):
    """Programs compiled again (an edited shader: the cache forgotten, the recheck due) start
    with no remembered uniforms; the frame must equal the first."""
    s = base_settings()
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(fan())
        r.set_head(ball())
        first = r.render_image(CAM, LIGHTS)
        slots = r.get_pass("head")._programs._slots
        name = "head_shade" if "head_shade" in slots else "head"   # head_shade.comp: a single-sample target
        head = slots[name][1]
        monkeypatch.setattr(glsl, "RECHECK_SECONDS", 0.0)
        glsl.clear_cache(gl)
        again = r.render_image(CAM, LIGHTS)
        assert r.get_pass("head")._programs._slots[name][1] is not head   # compiled anew
        assert np.array_equal(again, first)
    finally:
        r.release()


@pytest.mark.gpu
def test_lod_plan_kept_over_new_positions_and_made_again_for_a_new_box(gl):
    """A simulator's frames move the geometry version every frame: the coverage LOD's plan is
    kept while the view, the settings, the strands and their box are the same, and made again
    when one changes (here: instances, then another groom's box)."""
    r = Renderer(base_settings(lod_depth=8.0), ctx=gl, profile=False)
    try:
        r.set_strands(fan())
        r.set_head(ball())
        r.render(CAM, LIGHTS)
        plan = r.lod_plan()
        r.strands_changed()
        r.render(CAM, LIGHTS)
        assert r.lod_plan() is plan
        shifted = np.eye(4)
        shifted[:3, 3] = (0.3, 0.0, 0.0)
        r.set_instances([np.eye(4), shifted])
        r.render(CAM, LIGHTS)
        assert len(r.lod_plan().kept) == 2
        r.set_instances(None)
        r.set_strands(fan(0.05))
        r.render(CAM, LIGHTS)
        other = r.lod_plan()
        assert other is not plan and len(other.kept) == 1
    finally:
        r.release()


def test_set_uniforms_sets_a_dict_again_after_another_dict_wrote_a_shared_uniform():
    """A dict set whole is skipped only while no uniform of the program's plans was written since."""
    a, b = FakeUniform("f"), FakeUniform("f")
    prog = FakeProgram(u_a=a, u_b=b)
    first, second = {"u_a": 0.5, "u_b": 1.0}, {"u_b": 2.0}
    set_uniforms(prog, first)
    set_uniforms(prog, first)
    assert len(a.written) == 1 and len(b.written) == 1
    set_uniforms(prog, second)       # another pass's dict on the same program
    set_uniforms(prog, first)
    set_uniforms(prog, first)
    assert [struct.unpack("f", w)[0] for w in b.written] == [1.0, 2.0, 1.0]
    assert len(a.written) == 1       # its value never changed: not written again
    write_uniform(b, 3.0)            # a single write, not through a dict
    set_uniforms(prog, first)
    assert struct.unpack("f", b.written[-1])[0] == 1.0
    forget_uniforms(prog)
    set_uniforms(prog, first)
    assert len(a.written) == 2 and len(b.written) == 6


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_steady_frames_with_every_light_casting_write_no_uniform(gl, monkeypatch, rasterizer):
    """Each light's maps are drawn by programs of their own (gpu.glsl's instance), so frames
    after the first few write no uniform though every pass runs and the extra lights' maps are
    drawn in turn: shared with light 0's passes, each frame wrote the light views' uniforms
    over the other light's (26 writes a frame with three lights). And the frame is a fresh
    renderer's."""
    from mane.gpu import uniforms
    from mane.render import light_key

    monkeypatch.setattr(light_key, "KEEP", False)   # every pass every frame, as a moving groom's
    s = base_settings(rasterizer=rasterizer, shadow_lights=4, extra_shadow_map_size=32)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(fan())
        r.set_head(ball())
        for _ in range(4):
            r.render(CAM, LIGHTS)
        assert len(r.get_pass("extra_shadows")._doms) == 2   # lights 1 and 2 cast
        written = []
        real = uniforms.uniform_bytes
        monkeypatch.setattr(uniforms, "uniform_bytes", lambda u, v: written.append(u.name) or real(u, v))
        for _ in range(4):
            r.render(CAM, LIGHTS)
        assert written == []
        monkeypatch.setattr(uniforms, "uniform_bytes", real)
        image = r.render_image(CAM, LIGHTS)
    finally:
        r.release()
    assert np.array_equal(image, fresh(s, CAM, LIGHTS))
