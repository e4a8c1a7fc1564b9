"""Compile a scene's GPU programs before its Renderer and Simulator are made (issue 14, cold start).

A first launch on a GPU whose driver has not seen mane's programs spends seconds compiling
them (the H200: about 3 s, most of it two kernels, ``strand_solve.comp`` and ``hair_shade.comp``),
and a Renderer compiles each of its programs where a frame first needs it: in the first frame,
and in the frames after it where the scan-form tuner tries each form for the first time.
``warm_up`` moves all of that ahead: it simulates and draws a few strands of the same groom with
the same settings, colliders and head on the same context, once per scan-conversion form the
tuner may choose, moving and still frames, and releases them. The programs stay in the context's
program cache (``mane.gpu.glsl``), so the real Renderer and Simulator made afterwards compile
nothing; the CLI shows the compiles on a progress line (``mane.progress.compiles_shown``).

It saves no time overall: it moves the compiles to where a progress line can stand for them,
and the first frames of the scene come at their steady pace. A second launch finds the programs
in the driver's shader cache and its warm-up takes a fraction of a second.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from .errors import UsageError
from .phases import phase, watching

WARM_GUIDES = 16          # guides of the groom the warm-up simulates and draws
WARM_SIZE = (64, 48)      # the warm-up frames' size (the programs do not depend on it but for ms_smooth's factor)
MOVING_FRAMES = 2         # frames a form, the hair moving (every pass drawn)
STILL_FRAMES = 3          # then frames of a still picture (refine: its finer maps, the sample resolve)


def _few(groom, n: int):
    """``n`` guides spread over ``groom`` (its box and strand shape kept)."""
    count = int(groom.num_strands)
    if count <= n:
        return groom
    return groom.subset(np.unique(np.linspace(0, count - 1, n).round().astype(int)))


def _forms(ctx) -> list:
    """The scan-conversion forms a Renderer on ``ctx`` may dispatch: every form where the tuner
    chooses among them (scan_form.py), else the fixed rule's alone (None: leave it)."""
    from .gpu.capabilities import get_capabilities
    from .render.passes import raster_segment, scan_form

    if raster_segment.FORCED is not None or scan_form.TUNE is False:
        return [None]
    if scan_form.TUNE is None and get_capabilities(ctx).is_software:
        return [None]
    return list(range(max(scan_form.SITE_FORMS.values())))


def warm_up(ctx=None, *, groom, head=None, render_settings=None, sim_settings=None, colliders=(),
            points_per_strand: int | None = None, simulate: bool = True, render: bool = True,
            still: bool = True) -> dict:
    """Compile, on ``ctx``, what a Simulator of ``groom`` (``sim_settings``, ``colliders``,
    ``points_per_strand``, as Simulator takes them) and a Renderer (``render_settings``; drawing
    the simulator's strands when ``simulate``, else the groom, with ``head``) run in their first
    frames. ``render`` / ``simulate`` False: the other alone; ``still``: also a still picture's
    frames (a viewer's). Returns {"seconds", "programs" (compiled), "forms"}."""
    from .gpu import get_context
    from .render.passes import ms_smooth, raster_segment
    from .render.settings import RenderSettings

    if not (simulate or render):
        raise UsageError("warm_up: nothing to warm (simulate and render both False)")
    ctx = ctx if ctx is not None else get_context()
    few = _few(groom, WARM_GUIDES)
    rs = replace(render_settings if render_settings is not None else RenderSettings(), size=WARM_SIZE)
    forms = _forms(ctx) if render else [None]
    compiled = []

    def count(name, seconds, item):
        if name == "compile":
            compiled.append(item)

    t = time.perf_counter()
    kept = raster_segment.FORCED
    with phase("warm_up"), watching(count):
        sim = None
        try:
            if simulate:
                from .sim import Simulator

                sim = Simulator(few, colliders, sim_settings, ctx, points_per_strand=points_per_strand)
            for form in forms:
                raster_segment.FORCED = kept if form is None else form
                _frames(ctx, sim, few, head, rs, render, still)
            if render and ms_smooth.active_for(rs):
                ms_smooth.compile_every_factor(ctx)   # its grid's factor follows the frame's size
        finally:
            raster_segment.FORCED = kept
            if sim is not None:
                sim.release()
        ctx.finish()
    return {"seconds": time.perf_counter() - t, "programs": len(compiled), "forms": len(forms)}


def _frames(ctx, sim, groom, head, settings, render: bool, still: bool) -> None:
    """Steps (a simulator) and frames (``render``) on a Renderer of its own."""
    from .render import Renderer

    if not render:
        for _ in range(MOVING_FRAMES):
            sim.step()
        return
    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(sim if sim is not None else groom)
        if head is not None:
            r.set_head(head)
        camera = r.default_camera(points=None)
        for _ in range(MOVING_FRAMES):
            if sim is not None:
                sim.step()
                r.strands_changed()
            r.render(camera)
        if still:
            for _ in range(STILL_FRAMES):
                r.render(camera, refine=True)
    finally:
        r.release()
