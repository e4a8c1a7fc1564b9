"""What a renderer keeps from one frame to the next (uniform values, the scene's box, the
lighting uniforms of a frame) never shows in the image: a frame drawn after a setting, the
camera, the lights, the head or the strands changed equals a fresh renderer's frame of the
same scene. And the uniform writer skips a value only when the uniform holds it already."""
from __future__ import annotations

import struct
from dataclasses import replace

import numpy as np
import pytest

from mane.gpu.uniforms import forget_uniforms, uniform_bytes, write_uniform
from mane.groom import Groom
from mane.mesh import Mesh
from mane.render import Camera, Light, Renderer, RenderSettings


class FakeUniform:
    """moderngl's Uniform as write_uniform sees it: fmt, array_length, dimension, write."""

    def __init__(self, fmt: str, array_length: int = 1, dimension: int = 1):
        self.fmt, self.array_length, self.dimension = fmt, array_length, dimension
        self.written: list[bytes] = []

    def write(self, data: bytes) -> None:
        self.written.append(bytes(data))


def test_uniform_bytes_pack_as_moderngl_does():
    # moderngl's Uniform.value setter: struct.pack(fmt, ...) per element, joined
    assert uniform_bytes(FakeUniform("f"), 0.5) == struct.pack("f", 0.5)
    assert uniform_bytes(FakeUniform("3f", dimension=3), (1.0, 2.0, 3.0)) == struct.pack("3f", 1.0, 2.0, 3.0)
    assert uniform_bytes(FakeUniform("i", array_length=3), [4, 5, 6]) == struct.pack("3i", 4, 5, 6)
    assert uniform_bytes(FakeUniform("2f", 2, 2), [(1.0, 2.0), (3.0, 4.0)]) == struct.pack("4f", 1, 2, 3, 4)
    assert uniform_bytes(FakeUniform("f"), b"abcd") == b"abcd"


def test_write_uniform_skips_only_an_unchanged_value():
    u = FakeUniform("3f", dimension=3)
    write_uniform(u, (1.0, 2.0, 3.0))
    write_uniform(u, (1.0, 2.0, 3.0))
    assert len(u.written) == 1
    write_uniform(u, (1.0, 2.0, 3.5))
    assert u.written[-1] == struct.pack("3f", 1.0, 2.0, 3.5)
    write_uniform(u, (1.0, 2.0, 3.0))          # back to the first value: written again
    assert len(u.written) == 3
    f = FakeUniform("f")
    write_uniform(f, 1)
    write_uniform(f, 1.0)                      # another type: packed and written again
    assert len(f.written) == 2
    b = FakeUniform("16f")
    write_uniform(b, bytes(64))
    write_uniform(b, bytes(64))
    assert len(b.written) == 1
    write_uniform(b, b"\x01" + bytes(63))
    assert len(b.written) == 2


def test_forget_uniforms_makes_the_next_write_happen():
    class Prog:
        pass

    u = FakeUniform("f")
    prog = Prog()
    prog._members = {"u_x": u}
    write_uniform(u, 2.0)
    forget_uniforms(prog)
    write_uniform(u, 2.0)
    assert len(u.written) == 2


def test_render_code_writes_uniforms_only_through_the_writer():
    """A direct write would leave the remembered value stale, and a later equal write skipped."""
    import re
    from pathlib import Path

    import mane.render

    root = Path(mane.render.__file__).parent
    direct = re.compile(r"""\w+\[[^\]]+\]\.(value\s*=(?!=)|write\()|\b(prog|program|cs|shader|pack|merge)\w*\[["'][^\]]+\]\s*=(?!=)""")
    found = [f"{path.relative_to(root)}:{n}: {line.strip()}"
             for path in sorted(root.rglob("*.py")) for n, line in enumerate(path.read_text().splitlines(), 1)
             if direct.search(line) and not line.lstrip().startswith("#")]
    assert not found, "write uniforms through set_uniform / write_uniform:\n" + "\n".join(found)


# ---------------------------------------------------------------------------- whole frames
CAM = Camera(eye=(0.0, 0.05, 0.8), target=(0.0, 0.0, 0.0), fov_y=32.0, near=0.1, far=3.0)
CAM2 = Camera(eye=(0.35, 0.15, 0.7), target=(0.0, -0.02, 0.0), fov_y=28.0, near=0.1, far=3.0)
LIGHTS = [Light("directional", (1.0, 1.2, 0.4), intensity=2.0), Light("directional", (-1.0, 0.8, 0.2), intensity=1.0),
          Light("directional", (0.0, 0.3, 1.0), intensity=0.4)]
LIGHTS2 = [Light("directional", (-0.6, 1.0, 0.8), intensity=1.5, color=(1.0, 0.8, 0.6)), LIGHTS[1], LIGHTS[2]]


def fan(shift: float = 0.0) -> Groom:
    t = np.linspace(0, 1, 8)
    return Groom.from_strands([np.c_[0.08 * np.cos(a) * t + shift, 0.15 - 0.3 * t, 0.08 * np.sin(a) * t + 0.03]
                               for a in np.linspace(0, np.pi, 9)])


def ball(radius=0.09) -> Mesh:
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    return Mesh(np.asarray(s.vertices) + (0.0, 0.02, -0.05), np.asarray(s.faces))


def base_settings(**kw) -> RenderSettings:
    s = dict(size=(64, 48), msaa=1, shadows="deep_opacity", shadow_map_size=64, strands_per_guide=4, width=0.003,
             min_pixel_width=1.0, shadow_lights=2, rasterizer="compute")
    s.update(kw)
    return RenderSettings(**s)


def fresh(settings, camera, lights, groom=None, head=None, transform=None) -> np.ndarray:
    r = Renderer(settings, profile=False)
    try:
        r.set_strands(groom if groom is not None else fan())
        r.set_head(head if head is not None else ball())
        if transform is not None:
            r.set_head_transform(transform)
        return r.render_image(camera, lights)
    finally:
        r.release()


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_a_frame_after_changes_equals_a_fresh_renderers_frame(gl, rasterizer):
    s1 = base_settings(rasterizer=rasterizer)
    r = Renderer(s1, ctx=gl, profile=False)
    try:
        r.set_strands(fan())
        r.set_head(ball())
        first = r.render_image(CAM, LIGHTS)
        # the same frame again: nothing kept from the first changes it
        assert np.array_equal(r.render_image(CAM, LIGHTS), first)
        # settings the viewer changes between frames: lighting, shadows, tone, hair look
        s2 = replace(s1, ambient=0.3, exposure=1.4, shadow_bias=2.0 * s1.shadow_bias, pcf=3, head_pcf=1,
                     width=0.004, skin_color=(0.5, 0.3, 0.25), background=(0.1, 0.2, 0.3))
        r.settings = s2
        changed = r.render_image(CAM, LIGHTS)
        assert not np.array_equal(changed, first)
        assert np.array_equal(changed, fresh(s2, CAM, LIGHTS))
        # another camera, then other lights
        assert np.array_equal(r.render_image(CAM2, LIGHTS), fresh(s2, CAM2, LIGHTS))
        assert np.array_equal(r.render_image(CAM2, LIGHTS2), fresh(s2, CAM2, LIGHTS2))
        # new strands (another box: the light's view moves) and a new head
        moved, head = fan(0.04), ball(0.08)
        r.set_strands(moved)
        r.set_head(head)
        assert np.array_equal(r.render_image(CAM2, LIGHTS2), fresh(s2, CAM2, LIGHTS2, moved, head))
        # back to the first settings and view: the first frame again
        r.settings = s1
        r.set_strands(fan())
        r.set_head(ball())
        assert np.array_equal(r.render_image(CAM, LIGHTS), first)
    finally:
        r.release()


@pytest.mark.gpu
def test_two_renderers_sharing_programs_do_not_see_each_others_uniforms(gl):
    """Programs are compiled once per context and shared: a uniform another renderer wrote in
    between must be written again."""
    s_a, s_b = base_settings(), base_settings(ambient=0.35, exposure=1.3)
    a, b = Renderer(s_a, ctx=gl, profile=False), Renderer(s_b, ctx=gl, profile=False)
    try:
        for r in (a, b):
            r.set_strands(fan())
            r.set_head(ball())
        img_a = a.render_image(CAM, LIGHTS)
        img_b = b.render_image(CAM2, LIGHTS2)
        assert np.array_equal(a.render_image(CAM, LIGHTS), img_a)
        assert np.array_equal(b.render_image(CAM2, LIGHTS2), img_b)
        assert np.array_equal(img_a, fresh(s_a, CAM, LIGHTS))
    finally:
        a.release()
        b.release()


LIGHT_SPACE = ["shadow_map", "deep_opacity", "extra_shadows", "skin_bounce"]   # base_settings' frame


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_light_space_targets_are_reused_while_lights_hair_and_head_are_still(gl, rasterizer):
    """The shadow and opacity maps and the skin's bounce follow the lights, the hair and the head,
    not the camera (light_key.py): a frame reuses them while those are still, and draws them
    again after any of them changed; every frame equals a fresh renderer's."""
    s = base_settings(rasterizer=rasterizer)
    r = Renderer(s, ctx=gl, profile=False)

    def frame(camera, lights):
        kept = r.render(camera, lights).kept
        return kept, r.read_image()

    try:
        r.set_strands(fan())
        r.set_head(ball())
        kept, first = frame(CAM, LIGHTS)
        assert kept == []
        kept, again = frame(CAM, LIGHTS)
        assert kept == LIGHT_SPACE and np.array_equal(again, first)
        assert r.stats()["reused_passes"] == LIGHT_SPACE
        kept, image = frame(CAM2, LIGHTS)                    # the camera moved: the maps are the same
        assert kept == LIGHT_SPACE and np.array_equal(image, fresh(s, CAM2, LIGHTS))
        kept, image = frame(CAM2, LIGHTS2)                   # other lights
        assert kept == [] and np.array_equal(image, fresh(s, CAM2, LIGHTS2))
        assert frame(CAM2, LIGHTS2)[0] == LIGHT_SPACE
        # positions written in place (a simulation step): the hair's maps and the skin's bounce again
        pos = np.frombuffer(r.strands.positions.read(), np.float32).reshape(-1, 4).copy()
        pos[:, 0] += 0.02
        r.strands.positions.write(pos.tobytes())
        r.strands_changed()
        r.strands.bbox(refresh=True)
        kept, image = frame(CAM2, LIGHTS2)
        moved = fan(0.02)
        assert kept == [] and np.array_equal(image, fresh(s, CAM2, LIGHTS2, moved))
        # the head moved: its shadow map (the skin's bounce, the maps that read it) again
        m = np.eye(4)
        m[:3, 3] = (0.0, -0.01, 0.01)
        r.set_head_transform(m)
        kept, image = frame(CAM2, LIGHTS2)
        assert kept == [] and np.array_equal(image, fresh(s, CAM2, LIGHTS2, moved, transform=m))
        r.set_head(r.head)   # uploaded again (its vertices may have been written in place)
        assert frame(CAM2, LIGHTS2)[0] == [] and frame(CAM2, LIGHTS2)[0] == LIGHT_SPACE
        # the distance LOD measures from the camera: a camera move thins the hair in every map
        lod = replace(s, lod=True, lod_start=0.2, lod_end=1.0, lod_percent=0.3)
        r.settings = lod
        frame(CAM, LIGHTS2)
        kept, image = frame(CAM2, LIGHTS2)
        assert kept == [] and np.array_equal(image, fresh(lod, CAM2, LIGHTS2, moved, transform=m))
    finally:
        r.release()


@pytest.mark.gpu
def test_a_simulators_hair_reuses_the_light_space_targets_only_while_it_does_not_step(gl):
    """A simulator's buffer is read in place and its frames rebuilt every frame; its hair counts as
    moved when the simulator steps (as for a still picture), so a paused simulation reuses the maps
    and a step draws them again, the frame then equal to a fresh renderer's of the same buffer."""
    from mane.sim import Simulator

    sim = Simulator(fan(), ctx=gl)
    r = Renderer(base_settings(), ctx=gl, profile=False)
    try:
        r.set_strands(sim)
        r.set_head(ball())
        assert [r.render(CAM, LIGHTS).kept for _ in range(3)] == [[], LIGHT_SPACE, LIGHT_SPACE]
        for _ in range(5):
            sim.step()
        kept, image = r.render(CAM, LIGHTS).kept, r.read_image()
        assert kept == []
        other = Renderer(base_settings(), ctx=gl, profile=False)
        try:
            other.set_strands(sim)
            other.set_head(ball())
            assert np.array_equal(image, other.render_image(CAM, LIGHTS))
        finally:
            other.release()
        assert r.render(CAM, LIGHTS).kept == LIGHT_SPACE
    finally:
        r.release()
        sim.release()
