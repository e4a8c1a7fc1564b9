"""The lights after light 0 that cast (RenderSettings.shadow_lights; mane render: every light),
through maps of extra_shadow_map_size texels (at most shadow_map_size) whose deep opacity
darkens as light 0's map does (extra_shadows.matched_opacity, checked against the transmittance
of one strand over a texel from first principles)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from mane.render import Renderer, RenderSettings
from mane.render.coverage_lod import mean_width
from mane.render.lights import default_lights
from mane.render.passes.extra_shadows import extra_map_size, matched_opacity


def one_strand(so: float, density: float, c: float) -> tuple[float, float]:
    """(the map's transmittance exp(-density * so * c), the strands': a strand over a part c of the
    texel, opaque but for exp(-density * so), the rest clear)."""
    t = math.exp(-density * so)
    return math.exp(-density * so * c), 1.0 - c * (1.0 - t)


@hsettings(max_examples=200, deadline=None)
@given(so=st.floats(0.05, 2.0), density=st.floats(0.5, 6.0), width=st.floats(1e-5, 2e-3),
       main_texel=st.floats(1e-4, 4e-3), coarser=st.floats(1.0, 16.0))
def test_matched_opacity_darkens_as_light_0s_map(so, density, width, main_texel, coarser):
    s = RenderSettings(strand_opacity=so, shadow_density=density, width=width, width_tip=1.0)
    assert mean_width(s) == pytest.approx(width)
    texel = main_texel * coarser
    so_x = matched_opacity(s, texel, main_texel)
    c0, cx = min(1.0, width / main_texel), min(1.0, width / texel)
    # the optical depth a map gives one strand, over the strands' own: the same ratio in both maps
    m0, t0 = one_strand(so, density, c0)
    mx, _ = one_strand(so_x, density, cx)
    _, tx = one_strand(so, density, cx)
    assert math.log(mx) / math.log(tx) == pytest.approx(math.log(m0) / math.log(t0), rel=1e-6)
    assert so_x <= so * (1 + 1e-9)                    # coarser texels: less opacity per unit coverage
    assert matched_opacity(s, main_texel, main_texel) == pytest.approx(so)


def test_matched_opacity_keeps_degenerate_settings():
    s = RenderSettings(strand_opacity=0.0)
    assert matched_opacity(s, 1e-3, 1e-4) == 0.0
    s = RenderSettings(strand_opacity=0.7, shadow_density=0.0)
    assert matched_opacity(s, 1e-3, 1e-4) == 0.7


def test_extra_map_size_is_at_most_light_0s():
    assert RenderSettings().shadow_lights == 4   # every light of the default rig casts
    assert extra_map_size(RenderSettings()) == RenderSettings().extra_shadow_map_size < RenderSettings().shadow_map_size
    assert extra_map_size(RenderSettings(shadow_map_size=128, extra_shadow_map_size=512)) == 128


@pytest.mark.gpu
def test_the_default_rig_casts_through_coarser_maps(gl):
    """Each of the default fill and rim lights gets a deep opacity map of extra_shadow_map_size
    texels, its view's texels the size ratio coarser than light 0's, its strands' opacity lower
    (matched_opacity), and the hair it shadows darker than with light 0 casting alone."""
    from test_render_tessellation import wavy_groom

    lights = default_lights()
    means = {}
    for casters in (1, 4):
        r = Renderer(RenderSettings(size=(64, 48), strands_per_guide=4, shadow_map_size=256, extra_shadow_map_size=64,
                                    shadow_lights=casters, draw_head=False, accumulate=1), ctx=gl, profile=False)
        try:
            r.set_strands(wavy_groom(guides=6, points=8))
            img = r.render_image(r.default_camera(), lights).astype(float)
            f = r.last_frame
            doms = f.targets.get("extra_doms", [])
            if casters == 1:
                assert doms == [] and f.shadow_views == []
            else:
                assert [d.size for d in doms] == [(64, 64)] * 2
                for (view, _), light in zip(f.shadow_views, lights[1:]):
                    main = r.light_view(light)
                    assert view.pixel_size == pytest.approx(main.pixel_size * 256 / 64)
                xdom = r.get_pass("extra_shadows")._doms[0]
                assert xdom.strand_opacity(f.shadow_views[0][0]) < r.settings.strand_opacity
            means[casters] = img[img.sum(axis=2) > 0].mean()
        finally:
            r.release()
    assert means[4] < means[1]


@pytest.mark.gpu
def test_moving_hair_redraws_one_extra_light_a_frame(gl, monkeypatch):
    """Frame after frame, one extra light's maps are drawn again in turn, the other's kept; the
    first frame and new settings draw both; and once the hair stops, a frame shows what a fresh
    renderer draws, every map current."""
    from test_render_tessellation import wavy_groom

    from mane.render import light_key
    from mane.render.passes import extra_shadows

    monkeypatch.setattr(light_key, "KEEP", False)   # every light-space pass runs, as when the hair moves
    drawn = []
    real = extra_shadows._LightDeepOpacity.run

    def run(self, frame):
        drawn[-1].append(self.renderer.get_pass("extra_shadows")._doms.index(self))
        return real(self, frame)

    monkeypatch.setattr(extra_shadows._LightDeepOpacity, "run", run)
    settings = RenderSettings(size=(64, 48), strands_per_guide=4, shadow_map_size=128, extra_shadow_map_size=64,
                              draw_head=False, accumulate=1, shadow_lights=4)
    groom = wavy_groom(guides=6, points=8)
    r = Renderer(settings, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        cam, lights = r.default_camera(), default_lights()
        for _ in range(5):
            drawn.append([])
            r.render(cam, lights)
        assert drawn[0] == [0, 1] and drawn[1:] == [[1], [0], [1], [0]]
        r.settings = settings.replace(strand_opacity=0.6)
        drawn.append([])
        r.render(cam, lights)
        assert drawn[-1] == [0, 1]
        shown = r.render_image(cam, lights)
        fresh = Renderer(r.settings, ctx=gl, profile=False)
        try:
            fresh.set_strands(groom)
            np.testing.assert_array_equal(shown, fresh.render_image(cam, lights))
        finally:
            fresh.release()
    finally:
        r.release()


@pytest.mark.gpu
def test_extra_lights_compiled_in_leave_one_lights_picture_alone(gl):
    """shadow_lights 4 under one light draws what shadow_lights 1 draws, on both rasterisers:
    llvmpipe's compute shaders lost the hair's multiply scattered light (the curly head's hair
    0.6x as bright) while lighting.glsl indexed the extra lights' sampler arrays by a variable."""
    from mane.grooming.scene import default_scene
    from mane.render import Light

    groom, head = default_scene(num_guides=120, points=12, subdivisions=3)
    light = [Light("directional", (0.35, 0.8, 0.5), (1.0, 1.0, 1.0), 3.0)]
    for ras in ("compute", "hardware"):
        imgs = []
        for casters in (1, 4):
            r = Renderer(RenderSettings(size=(96, 72), msaa=4, shadow_map_size=128, rasterizer=ras, shadow_lights=casters,
                                        accumulate=1), ctx=gl, profile=False)
            try:
                r.set_strands(groom)
                r.set_head(head)
                imgs.append(r.render_image(r.default_camera(), light).astype(int))
            finally:
                r.release()
        assert np.abs(imgs[0] - imgs[1]).max() <= 2, ras


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_the_extra_lights_look_up_builds_in_both_forms(gl, monkeypatch, rasterizer):
    """lighting.glsl's XLIGHT_CONST: the extra lights' sampler arrays indexed by constants on a CPU
    rasteriser (llvmpipe loses other look-ups otherwise), by the light on a GPU (one copy of the
    look-up). CI has no GPU, so the GPU's form is built here with the capabilities saying GPU (only
    shadow_defines reads them): it compiles and draws a frame with both extra lights casting, lit
    and finite (its picture is checked on the H200, docs/performance.md)."""
    import dataclasses

    from mane.gpu import glsl
    from mane.gpu.capabilities import get_capabilities
    from mane.render.passes import base
    from test_render_tessellation import wavy_groom

    assert base.shadow_defines(gl, RenderSettings())["XLIGHT_CONST"] == int(get_capabilities(gl).is_software)
    monkeypatch.setattr(base, "get_capabilities", lambda ctx: dataclasses.replace(get_capabilities(ctx), is_software=False))
    assert base.shadow_defines(gl, RenderSettings())["XLIGHT_CONST"] == 0
    built = []
    real = glsl.load_source
    monkeypatch.setattr(glsl, "load_source", lambda path, defines=None, *a, **k: (
        built.append((str(path), dict(defines or {}))), real(path, defines, *a, **k))[1])
    glsl.clear_cache(gl)
    r = Renderer(RenderSettings(size=(48, 36), strands_per_guide=2, shadow_map_size=64, extra_shadow_map_size=32,
                                rasterizer=rasterizer, accumulate=1), ctx=gl, profile=False)
    try:
        r.set_strands(wavy_groom(guides=6, points=8))
        img = r.render_image(r.default_camera(), default_lights())
        assert len(r.last_frame.shadow_views) == 2
    finally:
        r.release()
        glsl.clear_cache(gl)
    shading = [d for p, d in built if p.endswith(("hair_shade.comp", "hair.frag")) and d.get("XSHADOWS")]
    assert shading and all(d["XLIGHT_CONST"] == 0 for d in shading)
    assert np.isfinite(img).all() and img.max() > 0
