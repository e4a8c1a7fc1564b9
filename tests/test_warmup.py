"""mane.warm_up (issue 14, cold start): a scene's programs compiled before its Simulator and
Renderer exist, so that they and their first frames compile nothing."""
from __future__ import annotations

import pytest

from mane import phases


def _scene(S=48, N=8):
    from mane.bench import sim_bench

    head = sim_bench.head_mesh()
    return (sim_bench.scalp_groom(S, N), head, sim_bench.full_solver_settings(16),
            sim_bench.full_solver_colliders(16, head), N)


def _compiled(fn) -> list:
    """The programs compiled while ``fn()`` runs (gpu.glsl's "compile" phases)."""
    out = []
    with phases.watching(lambda name, seconds, item: out.append(item) if name == "compile" else None):
        fn()
    return out


def _one_frame(ctx, settings, groom, head) -> None:
    """A frame of ``groom`` on ``head`` by a Renderer of its own."""
    from mane.render import Renderer

    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        r.render(r.default_camera(points=None))
    finally:
        r.release()


def _run_scene(ctx, settings, groom, head, sim_settings, colliders, N, still=True):
    from mane.render import Renderer
    from mane.sim import Simulator

    sim = Simulator(groom, colliders, sim_settings, ctx, points_per_strand=N)
    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(sim)
        r.set_head(head)
        cam = r.default_camera(points=None)
        for _ in range(3):
            sim.step()
            r.strands_changed()
            r.render(cam)
        if still:
            for _ in range(3):
                r.render(cam, refine=True)
        ctx.finish()
    finally:
        r.release()
        sim.release()


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_after_a_warm_up_the_scene_compiles_nothing(rasterizer):
    """On a context of its own each (the program cache is per context): the scene alone compiles
    its programs (the control: the count the test holds the warm-up to); after warm_up with the
    same settings, colliders and head, a Simulator and Renderer of more strands and a larger
    frame, moving and still, compile none."""
    from mane.gpu.context import headless_context
    from mane.render import RenderSettings
    from mane.warmup import warm_up

    groom, head, sim_settings, colliders, N = _scene()
    settings = RenderSettings(size=(96, 72), strands_per_guide=2, rasterizer=rasterizer, shadow_map_size=64,
                              still_shadow_map_size=128)
    cold = headless_context()
    try:
        control = _compiled(lambda: _run_scene(cold, settings, groom, head, sim_settings, colliders, N))
    finally:
        cold.release()
    assert len(control) >= 10 and "strand_solve.comp" in control
    ctx = headless_context()
    try:
        info = warm_up(ctx, groom=groom, head=head, render_settings=settings, sim_settings=sim_settings,
                       colliders=colliders, points_per_strand=N)
        assert info["programs"] >= len(set(control)) and info["seconds"] > 0
        assert _compiled(lambda: _run_scene(ctx, settings, groom, head, sim_settings, colliders, N)) == []
    finally:
        ctx.release()


@pytest.mark.gpu
def test_a_warm_up_compiles_every_scan_form_the_tuner_may_pick(monkeypatch):
    """With the tuner on (a GPU's renderer; forced on here), the warm-up draws once per form, so
    that a probe's first use of a form compiles nothing: then a frame forced to each form (the
    hair raster's three, the opacity map's two) compiles none. The forced form is restored."""
    from mane.gpu.context import headless_context
    from mane.render import RenderSettings
    from mane.render.passes import raster_segment, scan_form
    from mane.warmup import warm_up

    monkeypatch.setattr(scan_form, "TUNE", True)
    monkeypatch.setattr(raster_segment, "FORCED", None)
    groom, head, sim_settings, colliders, N = _scene(S=24)
    settings = RenderSettings(size=(64, 48), strands_per_guide=2, rasterizer="compute", shadow_map_size=64)
    ctx = headless_context()
    try:
        info = warm_up(ctx, groom=groom, head=head, render_settings=settings, simulate=False, still=False)
        assert info["forms"] == 3 and raster_segment.FORCED is None
        def forced(form):
            def run():
                raster_segment.FORCED = form
                try:
                    _one_frame(ctx, settings, groom, head)
                finally:
                    raster_segment.FORCED = None
            return run

        for form in (0, 1, 2):
            assert _compiled(forced(form)) == [], form
    finally:
        ctx.release()


def test_a_warm_up_of_nothing_is_refused():
    from mane.errors import UsageError
    from mane.warmup import warm_up

    with pytest.raises(UsageError, match="nothing to warm"):
        warm_up(object(), groom=None, simulate=False, render=False)


@pytest.mark.gpu
@pytest.mark.parametrize("every_factor", [False, True])
def test_a_warm_up_compiles_the_smoothing_grid_of_any_frame_size(monkeypatch, every_factor):
    """The multiply scattered light's smoothing grid (ms_smooth.py) has cells of 1, 2 or 4 pixels
    by the frame's size and the hair's distance; the warm-up's small frames pick one, so it
    compiles the others' programs too: a frame ten times larger then compiles nothing (without
    that, it compiles its factor's, the control)."""
    from mane.gpu.context import headless_context
    from mane.render import RenderSettings
    from mane.render.passes import ms_smooth
    from mane.warmup import warm_up

    if not every_factor:
        monkeypatch.setattr(ms_smooth, "compile_every_factor", lambda ctx: None)
    groom, head, _, _, _ = _scene(S=24)
    small = RenderSettings(size=(64, 48), strands_per_guide=2, shadow_map_size=64)
    assert ms_smooth.active_for(small)
    ctx = headless_context()
    try:
        warm_up(ctx, groom=groom, head=head, render_settings=small, simulate=False, still=False)

        big = RenderSettings(size=(640, 480), strands_per_guide=2, shadow_map_size=64)
        compiled = _compiled(lambda: _one_frame(ctx, big, groom, head))
        assert compiled == [] if every_factor else compiled and set(compiled) == {"ms_smooth.comp"}
    finally:
        ctx.release()
