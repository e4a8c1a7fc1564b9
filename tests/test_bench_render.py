"""``mane bench render``: the JSON's structure, every sweep there, every timing positive.

Nothing here checks speed: llvmpipe on a shared CPU is what the tests run on.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import os

import pytest

from mane.bench import render_bench


@pytest.fixture(scope="module")
def quick(gl, tmp_path_factory):
    """One ``mane bench render --quick --json --out FILE`` through the CLI: (parsed stdout, file text, stderr)."""
    from mane.app.cli import main

    out_file = tmp_path_factory.mktemp("bench") / "render.json"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main(["bench", "render", "--quick", "--json", "--out", str(out_file)])
    assert rc == 0, stderr.getvalue()
    return json.loads(stdout.getvalue()), out_file.read_text(), stderr.getvalue()


def _positive(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


def _rows(result, bench, status=None):
    return [r for r in result["results"] if r["bench"] == bench and (status is None or r["status"] == status)]


@pytest.mark.slow
def test_envelope_and_top_level(quick):
    result, file_text, stderr = quick
    assert set(result) == {"meta", "results", "targets", "sweeps"}
    assert json.loads(file_text) == result          # --out writes the same object
    meta = result["meta"]
    for key in ("date", "mane_version", "renderer", "vendor", "gl_version", "driver", "gpu_memory",
                "settings", "timing", "mode"):
        assert key in meta, key
    assert meta["mode"] == "quick" and meta["benchmark"] == "render"
    # the driver settings that change the figures, as the run had them
    assert meta["host"]["driver_env"] == {k: os.environ.get(k) for k in
                                          ("__GL_THREADED_OPTIMIZATIONS", "__GL_SHADER_DISK_CACHE",
                                           "MESA_SHADER_CACHE_DISABLE")}
    assert meta["timing"]["frame_source"] in ("gpu-timer", "cpu")
    assert meta["timing"]["pass_source"] in ("gpu-timer", "cpu")
    names = set(meta["timing"]["pass_names"])
    assert "resolve" in names and ("hair" in names or "hair_compute" in names)   # by hardware or compute
    assert "render_settings_fields" in meta["settings"]
    assert "hunz_shading" in stderr                 # progress goes to stderr, not into the JSON


@pytest.mark.slow
def test_every_sweep_present_with_measured_rows(quick):
    result = quick[0]
    assert set(result["sweeps"]) == set(render_bench.SECTIONS)
    for section in render_bench.SECTIONS:
        rows = _rows(result, section)
        assert rows, f"no {section} rows"
        assert _rows(result, section, "ok"), f"no {section} configuration measured: {[r['reason'] for r in rows]}"
        summary = result["sweeps"][section]
        assert summary["configurations"] == len(rows)
        assert summary["ok"] + summary["skipped"] + summary["error"] == len(rows)
        assert summary["reference"]
    for r in result["results"]:
        assert r["status"] in ("ok", "skipped", "error")
        if r["status"] != "ok":
            assert r["reason"], r["name"]
        if r["status"] == "error":
            assert r["traceback"]


@pytest.mark.slow
def test_timings_positive(quick):
    for r in quick[0]["results"]:
        if r["status"] != "ok" or r["bench"] == "still":
            continue
        for key in ("frame_ms", "passes_sum_ms", "wall_ms", "submit_ms"):
            s = r[key]
            assert all(_positive(s[k]) for k in ("mean", "median", "p95", "min", "max")), (r["name"], key, s)
            assert s["n"] == r["frames_timed"] >= 1
        assert _positive(r["pipelined_ms"]) and _positive(r["fps"]) and _positive(r["first_frame_s"])
        assert r["warmup_frames"] == 3
        assert r["passes_ms"] and all(p["mean"] >= 0 for p in r["passes_ms"].values())
        hair = r["passes_ms"].get("hair") or r["passes_ms"]["hair_compute"]   # by hardware or compute
        assert _positive(hair["mean"]), r["name"]
        if "hair_compute" in r["passes_ms"]:   # its sections are inside it, not added again
            inner = r["passes_ms"]["hair_raster"]["mean"] + r["passes_ms"]["hair_shade"]["mean"]
            assert inner <= hair["mean"] * 1.05 and r["passes_sum_ms"]["mean"] < sum(
                p["mean"] for p in r["passes_ms"].values())
        assert _positive(r["rendered_strands"]) and _positive(r["rendered_segments"])
        assert isinstance(r["settings"], dict) and r["settings"]["size"] == r["size"]


@pytest.mark.slow
def test_sweeps_cover_the_seeds_parameters(quick):
    result = quick[0]
    cfg = render_bench.MODE_CONFIG["quick"]
    # Hunz Fig. 33: every shading model at every strand count
    models = render_bench.shading_models()
    got = {(r["rendered_strands"], r["shading"]) for r in _rows(result, "hunz_shading", "ok")}
    assert got == {(n, m) for n in cfg["hunz_strands"] for m in models}
    # Hunz Fig. 36: every shadow method the renderer has, x map size x PCF
    methods = render_bench.shadow_methods()
    assert methods[0] == "none" and {"shadow_map", "deep_opacity"} <= set(methods)
    assert result["sweeps"]["hunz_shadows"]["methods"] == methods
    rows = _rows(result, "hunz_shadows")
    assert {r["shadows"] for r in rows} == set(methods)
    for m in methods[1:]:
        assert {(r["shadow_map_size"], r["pcf"]) for r in rows if r["shadows"] == m} == \
            {(s, p) for s in cfg["shadow_sizes"] for p in cfg["shadow_pcf"]}
    # Vulkan: guides, divisions, strands per guide, PCF taps
    assert [r["parameter"] for r in _rows(result, "vulkan_guides")] == list(cfg["vulkan_guides"])
    assert [r["parameter"] for r in _rows(result, "vulkan_divisions")] == list(cfg["vulkan_divisions"])
    assert [r["parameter"] for r in _rows(result, "vulkan_strands_per_guide")] == list(cfg["vulkan_spg"])
    assert [r["parameter"] for r in _rows(result, "vulkan_pcf")] == list(cfg["vulkan_pcf_taps"])
    div = _rows(result, "vulkan_divisions", "ok")
    assert all(r["rendered_segments"] == r["rendered_strands"] * r["parameter"] for r in div)   # exact divisions
    spg = _rows(result, "vulkan_strands_per_guide", "ok")
    assert all(r["rendered_strands"] == r["guides"] * r["parameter"] for r in spg)
    # Chen Table 5: every distance with LOD on and off (on: skipped with a reason when the renderer has no LOD)
    chen = _rows(result, "chen_lod")
    assert {(r["distance"], r["lod"]) for r in chen} == {(d, s) for d in cfg["chen_distances"] for s in ("on", "off")}
    lod = result["sweeps"]["chen_lod"]["lod"]
    if not lod["available"]:
        assert all(r["status"] == "skipped" and "LOD" in r["reason"] for r in chen if r["lod"] == "on")
    offs = sorted((r for r in chen if r["lod"] == "off" and r["status"] == "ok"), key=lambda r: r["distance"])
    assert all(a["camera_distance_m"] < b["camera_distance_m"] for a, b in zip(offs, offs[1:]))
    # Woodhouse 5.1: with and without 4x MSAA
    wood = _rows(result, "woodhouse_msaa", "ok")
    assert {r["msaa"] for r in wood if r["shadows"] == "deep_opacity"} == {1, 4}
    # samples a pixel: the raster units' MSAA, or the compute rasteriser's grid (a GPU's auto)
    assert all(r["renderer_stats"]["raster_samples"] == r["msaa"] for r in wood)


@pytest.mark.slow
def test_targets(quick):
    t = quick[0]["targets"]
    assert t["target_ms"] == render_bench.TARGET_MS == 4.0
    assert "full_head_50k_ms" in t and isinstance(t["met"], bool)
    # quick mode measures a small stand-in and does not claim the target
    assert t["full_head_50k_ms"] is None and t["met"] is False and "quick" in t["note"]
    assert _positive(t["stand_in"]["value_ms"]) and _positive(t["stand_in"]["frame_ms"])
    row = _rows(quick[0], "target", "ok")[0]
    s = row["settings"]
    assert (s["shading"], s["shadows"], s["shadow_map_size"], s["msaa"], s["segments"]) == \
        (render_bench.TARGET_SHADING, "deep_opacity", 512, 4, 32)
    assert row["rendered_segments"] == row["rendered_strands"] * 32
    # the row's frames draw every pass; its still_hair block the same frame with the light-space
    # targets reused (the stand-in has a head: its skin's bounce too)
    still = row["still_hair"]
    assert still["kept"] == ["shadow_map", "deep_opacity", "extra_shadows", "skin_bounce"]
    assert _positive(still["pipelined_ms"]) and _positive(still["submit_bare_ms"]["median"])
    assert t["stand_in"]["still_hair"]["kept"] == still["kept"]
    orbit = row["orbit"]   # and the frame while the camera turns
    assert orbit["degrees_a_frame"] == render_bench.ORBIT_DEGREES
    assert _positive(orbit["pipelined_ms"]) and _positive(orbit["submit_bare_ms"]["median"])
    assert t["stand_in"]["orbit"]["pipelined_ms"] == orbit["pipelined_ms"]
    # and with every frame drawn (the row's own frames are played from their recording once confirmed)
    assert _positive(row["drawn"]["submit_bare_ms"]["median"])
    assert t["stand_in"]["drawn"]["cpu_submit_bare_median_ms"] == row["drawn"]["submit_bare_ms"]["median"]


@pytest.mark.slow
def test_text_output(quick):
    text = render_bench.format_text(quick[0])
    for title in ("Hunz Fig. 33", "Hunz Fig. 36", "Vulkan: guide strands", "Chen Table 5", "Woodhouse", "target:", "camera turning"):
        assert title in text


def test_orbit_turns_the_camera_every_frame():
    """Bench._orbit on a recording renderer: each frame (warm-up, issue, back to back) a camera
    of its own, turned ORBIT_DEGREES from the last about the target at the same distance."""
    import numpy as np

    from mane.render.camera import Camera

    class Ctx:
        def finish(self):
            pass

    class Prof:
        enabled = True

    class R:
        profiler = Prof()
        seen = []

        def render(self, cam, lights):
            assert self.profiler.enabled is False
            self.seen.append(cam)

    bench = render_bench.Bench.__new__(render_bench.Bench)
    bench.ctx = Ctx()
    cam = Camera(eye=(0.3, 0.1, 0.9), target=(0.0, 0.05, 0.0))
    r = R()
    out = render_bench.Bench._orbit(bench, r, cam, None, 8)
    assert r.profiler.enabled is True and out["submit_bare_ms"]["median"] >= 0.0
    assert len(r.seen) == 2 + 8 + 8   # a quarter of the frames turning before the clock
    t = np.asarray(cam.target)
    e = [np.asarray(c.eye) - t for c in [cam] + r.seen]
    assert len({tuple(x) for x in e}) == len(e)   # a new camera every frame
    for a, b in zip(e, e[1:]):
        assert np.linalg.norm(b) == pytest.approx(np.linalg.norm(a))
        ang = math.degrees(math.atan2(a[2] * b[0] - a[0] * b[2], a[0] * b[0] + a[2] * b[2]))
        assert ang == pytest.approx(render_bench.ORBIT_DEGREES)


def test_targets_met_logic():
    """_targets on made-up rows: the full configuration is compared with 4 ms."""
    def row(ms, strands=render_bench.TARGET_GUIDES * render_bench.TARGET_SPG, size=render_bench.TARGET_SIZE):
        st = {"mean": ms, "median": ms, "p95": ms}
        return {"bench": "target", "name": "t", "status": "ok", "reason": None, "rendered_strands": strands,
                "rendered_segments": strands * 32, "size": list(size), "frame_ms": st, "passes_sum_ms": st,
                "passes_ms": {"hair": st}, "wall_ms": st, "submit_ms": {"mean": 0.5}, "pipelined_ms": ms,
                "frame_source": "gpu-timer"}

    t = render_bench._targets([row(3.2)], "default")
    assert t["full_head_50k_ms"] == 3.2 and t["met"] is True and t["likely_bound"] == "gpu"
    t = render_bench._targets([row(4.5)], "default")
    assert t["met"] is False
    t = render_bench._targets([row(1.0, strands=512, size=(320, 240))], "quick")
    assert t["full_head_50k_ms"] is None and t["stand_in"]["frame_ms"] == 1.0
    skipped = dict(row(1.0), status="skipped", reason="out of GPU memory")
    t = render_bench._targets([skipped], "default")
    assert t["full_head_50k_ms"] is None and "out of GPU memory" in t["note"]


def test_settings_introspection():
    from mane.render.settings import RenderSettings

    s, dropped = render_bench.make_settings({"msaa": 1, "no_such_field": 3})
    assert isinstance(s, RenderSettings) and s.msaa == 1 and dropped == {"no_such_field": 3}
    with pytest.raises(render_bench.Skip):
        render_bench.make_settings({"msaa": 1}, required=("no_such_field",))
    with pytest.raises(render_bench.Skip):
        render_bench.make_settings({"msaa": 3})          # rejected by RenderSettings
    d = render_bench.settings_dict(s)
    assert set(d) == set(RenderSettings.field_names()) and json.dumps(d)
    on, off, how = render_bench.lod_switch()
    assert (on is None) == (off is None) and how
    if on is not None:
        assert RenderSettings(**on) != RenderSettings(**off)


def test_gapless_gpu_phase_runs_with_timer_queries(gl):
    """The GPU-preload phase (only used with GPU timer queries) on a tiny configuration, with the
    profilers forced to timestamps: it runs and reports its fields (llvmpipe's values mean little)."""
    bench = render_bench.Bench(gl, "quick", profiler_source="gpu-timer")
    bench.cfg = dict(bench.cfg, warmup=2, frames=2)
    try:
        bench.measure("test", "tiny", guides=4, points=9,
                      settings=dict(size=(64, 48), segments=8, strands_per_guide=2, shadows="none", msaa=1))
    finally:
        bench.release()
    row = bench.rows[-1]
    assert row["status"] == "ok", row.get("traceback")
    assert row["frame_source"] == row["pass_source"] == "gpu-timer"
    assert row["gpu_ms"]["n"] == row["frames_timed"] >= 2 and row["gpu_ms"]["mean"] >= 0
    assert ("hair" in row["gpu_passes_ms"] or "hair_compute" in row["gpu_passes_ms"]) and row["gpu_preload_ms"] >= 4.0
    assert bench._preload is None            # released


def test_a_spent_budget_skips_the_row_and_goes_on(gl):
    """Once the mode's time budget is spent, a configuration becomes a skipped row naming the
    budget (it once broke the whole bench: "generator didn't yield")."""
    bench = render_bench.Bench(gl, "quick")
    try:
        bench.started -= bench.cfg["total_budget_s"] + 1.0
        bench.measure("target", "after the budget", guides=4, points=8, settings={"size": (32, 32)})
        bench.measure("target", "and the next", guides=4, points=8, settings={"size": (32, 32)})
    finally:
        bench.release()
    assert [r["status"] for r in bench.rows] == ["skipped", "skipped"]
    assert all("time budget" in r["reason"] for r in bench.rows)


def test_the_still_row_times_the_averaged_frames_and_the_ones_after(quick):
    """The target frame as a still picture: the frames moved and folded into the mean (with the
    accumulate pass) and the frames after it, timed apart."""
    from mane.render import RenderSettings

    rows = [r for r in quick[0]["results"] if r["bench"] == "still"]
    assert len(rows) == 1 and rows[0]["status"] == "ok", rows
    r = rows[0]
    n = RenderSettings().accumulate
    assert r["accumulate"] == n and r["still_frames"] == n
    for phase in ("averaged", "after"):
        for key in ("frame_ms", "wall_ms", "submit_ms"):
            assert r[phase][key]["n"] == n and _positive(r[phase][key]["min"]), (phase, key)
    assert _positive(r["averaged"]["accumulate_ms"]["mean"])
    assert r["after"]["accumulate_ms"]["max"] == 0.0   # the mean is kept: the pass does not run
