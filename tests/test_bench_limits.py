"""``mane bench limits`` (the GPU's measured limits: DRAM copy bandwidth, the raster units'
peak, atomicMin throughput) and the compute rasteriser's statistics counter it is compared with
(hair_raster.comp's RASTER_STATS against the NumPy twin's scan conversion).

No speed is checked: the tests run on llvmpipe on a shared CPU; they check that every number is
there, positive, and that the summary's fractions are the JSON's own numbers divided.
"""
from __future__ import annotations

import numpy as np
import pytest

from mane.render import Renderer, RenderSettings
from mane.grooming.scene import default_scene

from mane.twins.raster import project, scan_segment
from test_render_tessellation import wavy_groom

pytestmark = pytest.mark.gpu


# --------------------------------------------------------------------------- the statistics counter
def twin_counts(expanded, proj_kw, scene_depth=None) -> dict:
    """What hair_raster.comp's counters should read, from the NumPy twin: samples scanned, those
    in front of the scene (each an atomic min + add), and per sample whether any segment hit it."""
    S, N, _ = expanded.shape
    W, H = proj_kw["size"]
    g = proj_kw["grid"]
    pr = project(expanded.reshape(-1, 8)[:, :4], **proj_kw)
    scanned = written = 0
    hit = np.zeros((H, W), bool)
    for strand in range(S):
        for j in range(N - 1):
            i = strand * N + j
            if not (pr["ok"][i] and pr["ok"][i + 1]):
                continue
            cov = scan_segment(pr["s"][i], pr["s"][i + 1], pr["window_z"][i], pr["window_z"][i + 1],
                               pr["half_width"][i], pr["half_width"][i + 1], pr["coverage"][i],
                               pr["coverage"][i + 1], (W, H))
            scanned += len(cov)
            for x, y, z, _ in cov:
                if not 0.0 <= z < 1.0 or (scene_depth is not None and z >= scene_depth[y // g, x // g]):
                    continue
                written += 1
                hit[y, x] = True
    return {"sample_visits": scanned, "sample_writes": written, "samples_hit": int(hit.sum())}


def _renderer(gl, groom, head=None, **kw):
    s = RenderSettings(**{"size": (96, 72), "msaa": 1, "shadows": "none", "draw_head": head is not None,
                          "rasterizer": "compute", **kw})
    r = Renderer(s, ctx=gl, profile=False)
    r.set_strands(groom)
    r.set_head(head)
    return r


@pytest.mark.parametrize("case", ["thin 2x2 samples", "head in front"])
def test_raster_stats_count_the_samples_the_twin_visits(gl, case):
    if case == "thin 2x2 samples":
        groom, head, kw = wavy_groom(), None, dict(msaa=4, strands_per_guide=4, segments=20)
    else:
        groom, head = default_scene(num_guides=60, points=8, subdivisions=3)
        kw = dict(strands_per_guide=2, segments=10)
    r = _renderer(gl, groom, head, **kw)
    try:
        hc = r.get_pass("hair_compute")
        cam = r.default_camera(0.0 if head is not None else 25.0)
        r.render(cam)
        image = r.read_image()
        got = hc.count_samples(cam)
        assert hc.count_stats is False
        assert np.array_equal(r.read_image(), image)    # the counters change nothing drawn
        e = r.get_pass("expand").read()
        v = r.last_frame.view
        W, H = hc.sample_size()
        scene = None
        if head is not None:
            _, depth = r.hdr_textures()
            scene = np.frombuffer(depth.read(), np.float32).reshape(H // r.raster_grid, W // r.raster_grid)
        want = twin_counts(e, dict(view_proj=v.view_proj, eye=v.eye, forward=v.forward, ortho=v.ortho,
                                   pixel_size=v.pixel_size, min_pixel_width=v.min_pixel_width, size=(W, H),
                                   grid=r.raster_grid), scene)
    finally:
        r.release()
    assert want["sample_visits"] > 1000
    if head is not None:
        assert want["sample_writes"] < 0.9 * want["sample_visits"]    # the head hides some
    # float32 on the GPU against float64 in the twin: a sample centre exactly on an edge may
    # fall either side, a few in ten thousand
    for k in ("sample_visits", "sample_writes"):
        assert abs(got[k] - want[k]) <= max(2, 1e-3 * want[k]), (k, got, want)
    bits = got["raster_atomic_bits"]
    assert bits in (32, 64)
    if bits == 64:
        assert got["raster_atomics"] == 2 * got["sample_writes"]
    else:   # the id pass: an atomicMax wherever a segment is at the sample's nearest depth
        extra = got["raster_atomics"] - 2 * got["sample_writes"]
        assert want["samples_hit"] * 0.998 - 2 <= extra <= got["sample_writes"]


# --------------------------------------------------------------------------- mane bench limits
def test_bench_limits_quick_measures_every_limit(gl, tmp_path):
    import contextlib
    import io
    import json

    from mane.app.cli import main
    from mane.bench import limits

    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main(["bench", "limits", "--quick", "--json", "--out", str(tmp_path / "limits.json")])
    assert rc == 0, stderr.getvalue()[-3000:]
    result = json.loads(stdout.getvalue())
    assert json.loads((tmp_path / "limits.json").read_text()) == result
    assert result["meta"]["benchmark"] == "limits" and result["meta"]["timing"]["source"] in ("cpu", "gpu-timer")
    rows = {r["name"]: r for r in result["results"]}
    names = [r["name"] for r in result["results"]]
    assert [r["bench"] for r in result["results"]].count("raster") == 2
    for r in result["results"]:
        if r["status"] != "ok":   # only 64-bit atomics may be missing, and only for want of the extension
            assert r["bench"] == "atomics" and r["bits"] == 64 and "GL_NV_shader_atomic_int64" in r["reason"]
            continue
        assert r["value"] > 0 and r["value_median"] > 0 and r["value"] >= r["value_median"], r
        assert r["unit"] and "GpuProfiler" in r["method"], r
    copy = next(r for r in result["results"] if r["bench"] == "dram")
    assert copy["bytes_per_run"] == 2 * copy["buffer_bytes"]
    assert copy["value"] == pytest.approx(copy["bytes_per_run"] / copy["time_ms"]["min"] / 1e6)
    for msaa in (1, 4):
        r = rows[next(n for n in names if n.startswith(f"msaa {msaa} "))]
        assert r["samples"] == msaa * r["pixels"] == msaa * r["triangles"] * r["triangle_pixels"]
        assert r["samples_per_s"] == pytest.approx(r["samples"] / r["time_ms"]["min"] * 1e3)
        assert result["peaks"]["raster"][str(msaa)]["triangles_per_s"] == r["triangles_per_s"]
    random32 = rows["atomicMin 32-bit random"]
    assert random32["ops"] == random32["threads"] * random32["ops_per_thread"]
    assert random32["words"] == 1920 * 1080 * 4
    assert result["peaks"]["atomic_min_per_s"]["32"] == random32["value"]
    assert "Atomics" in limits.format_text(result)
    # the context's framebuffer binding is given back: a renderer made now releases cleanly
    Renderer(RenderSettings(size=(8, 8)), ctx=gl, profile=False).release()


def test_distance_rows_divide_the_rows_by_the_limits():
    # no GL: made-up rows, so every fraction is known
    from mane.bench.limits import distance_rows

    ms = lambda v: {"mean": v, "median": v, "p95": v, "min": v, "max": v, "n": 3}  # noqa: E731
    results = {
        "sim": {"bandwidth": {"achieved_GBps": 2400.0, "peak_GBps": 4800.0, "fraction_of_peak": 0.5,
                              "peak_model": "H200", "configuration": "100000x32", "bytes_per_step": 1,
                              "time_ms": 0.1}},
        "limits": {"results": [], "peaks": {"dram_copy_GBps": 4000.0,
                                            "raster": {"4": {"triangles_per_s": 1e10, "samples_per_s": 4e10}},
                                            "atomic_min_per_s": {"64": 5e10}}},
        "render": {"results": [
            {"bench": "target", "name": "hw", "status": "ok", "rendered_segments": 1_000_000, "guides": 9,
             "size": [1920, 1080], "passes_ms": {"hair": ms(8.0)}, "gpu_passes_ms": {"hair": ms(4.0)},
             "renderer_stats": {"rasterizer": "hardware", "msaa": 4, "geometry": "ribbons"},
             "settings": {"depth_prepass": True}},
            {"bench": "target_rasterizer", "name": "cs", "status": "ok", "rendered_segments": 1_000_000,
             "guides": 9, "size": [1920, 1080], "passes_ms": {"hair_compute": ms(3.0), "hair_raster": ms(2.0)},
             "renderer_stats": {"rasterizer": "compute", "msaa": 1, "raster_samples": 4},
             "sample_visits": 30_000_000, "sample_writes": 20_000_000, "raster_atomics": 40_000_000,
             "raster_atomic_bits": 64},
            {"bench": "hunz_shading", "name": "lines", "status": "ok", "rendered_segments": 10,
             "passes_ms": {"hair": ms(1.0)}, "renderer_stats": {"rasterizer": "hardware", "msaa": 1,
                                                                "geometry": "lines"}},
            {"bench": "vulkan_pcf", "name": "1x", "status": "ok", "rendered_segments": 500,
             "passes_ms": {"hair": ms(1.0)}, "renderer_stats": {"rasterizer": "hardware", "msaa": 1},
             "settings": {}},
        ]},
    }
    rows = distance_rows(results)
    by = {(r["stage"], r["configuration"]): r for r in rows}
    assert len(rows) == 4   # solver, hardware target, compute target, the 1x row (lines: no triangles)
    solver = by[("solver", "100000x32")]
    assert solver["fraction"] == pytest.approx(0.6) and solver["tabulated_fraction"] == 0.5
    hw = by[("hair pass", "hw")]
    # 2 draws x 2 triangles x 1M segments in the gapless GPU 4 ms = 1e9 / s of 1e10
    assert hw["achieved"] == pytest.approx(1e9) and hw["fraction"] == pytest.approx(0.1)
    # samples estimated from the compute rasteriser's 30 M visits, 2 draws: 1.5e10 / s of 4e10
    assert hw["samples_per_s"] == pytest.approx(1.5e10) and hw["samples_fraction"] == pytest.approx(0.375)
    cs = by[("hair pass", "cs")]
    assert cs["path"].startswith("compute (64-bit")
    assert cs["achieved"] == pytest.approx(2e10) and cs["fraction"] == pytest.approx(0.4)
    one = by[("hair pass", "1x")]
    assert one["limit"] is None and one["fraction"] is None   # no 1x raster peak measured
    # without limits.json: the solver keeps its tabulated fraction
    del results["limits"]
    solver = next(r for r in distance_rows(results) if r["stage"] == "solver")
    assert solver["fraction"] is None and solver["tabulated_fraction"] == 0.5
