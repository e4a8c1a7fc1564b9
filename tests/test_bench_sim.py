"""``mane bench sim``: the JSON's structure and that every timing is there and positive.

Nothing here checks speed: llvmpipe on a shared CPU is what the tests run on.
"""
from __future__ import annotations

import contextlib
import io
import json
import math

import numpy as np
import pytest

from mane.bench import common, sim_bench


@pytest.fixture(scope="module")
def quick(gl, tmp_path_factory):
    """One ``mane bench sim --quick --json --out FILE`` through the CLI: (parsed stdout, file text, stderr)."""
    from mane.app.cli import main

    out_file = tmp_path_factory.mktemp("bench") / "sim.json"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main(["bench", "sim", "--quick", "--json", "--out", str(out_file)])
    assert rc == 0, stderr.getvalue()
    return json.loads(stdout.getvalue()), out_file.read_text(), stderr.getvalue()


def _positive(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


@pytest.mark.slow
def test_envelope_and_top_level(quick):
    result, file_text, stderr = quick
    assert set(result) == {"meta", "results", "targets", "bandwidth"}
    assert json.loads(file_text) == result          # --out writes the same object
    meta = result["meta"]
    for key in ("date", "mane_version", "renderer", "vendor", "gl_version", "driver", "gpu_memory",
                "settings", "timing", "mode"):
        assert key in meta, key
    assert meta["mode"] == "quick" and meta["benchmark"] == "sim"
    assert meta["timing"]["step_source"] in ("gpu-timer", "cpu")
    assert "dftl_core" in stderr                    # progress goes to stderr, not into the JSON


@pytest.mark.slow
def test_profiler_pass_names_match_the_simulator(quick):
    from mane.sim import PASSES

    timing = quick[0]["meta"]["timing"]
    assert timing["pass_names_match_simulator"] is True
    assert set(timing["pass_names"]) <= set(PASSES)
    assert {"integrate", "length", "velocity", "shape", "sdf", "friction", "volume"} <= set(timing["pass_names"])


@pytest.mark.slow
def test_every_section_measured_with_positive_timings(quick):
    rows = quick[0]["results"]
    assert not [r for r in rows if r["status"] == "error"], [r["reason"] for r in rows if r["status"] == "error"]
    for bench in ("dftl_core", "full_solver", "woodhouse", "grid_friction", "flip", "chen_shares"):
        ok = [r for r in rows if r["bench"] == bench and r["status"] == "ok"]
        assert ok, f"no {bench} configuration measured"
    for r in rows:
        if r["status"] != "ok":
            assert r["reason"]
            continue
        if r["bench"] in ("dftl_core", "full_solver", "woodhouse", "chen_shares"):
            for key in ("step_ms", "wall_ms", "profiled_wall_ms", "submit_ms"):
                s = r[key]
                assert all(_positive(s[k]) for k in ("mean", "median", "p95")), (r["name"], key, s)
                assert s["n"] == r["steps_timed"] >= 3
            assert _positive(r["pipelined_ms"]) and _positive(r["kernel_sum_ms"])
            assert all(v >= 0 for v in r["passes_ms"].values())
            assert _positive(r["passes_ms"]["integrate"])
    core = [r for r in rows if r["bench"] == "dftl_core" and r["status"] == "ok"]
    assert {(r["strands"], r["vertices"]) for r in core} == {(256, 16), (1000, 16), (256, 32), (1000, 32)}


@pytest.mark.slow
def test_full_solver_runs_every_pass(quick):
    rows = [r for r in quick[0]["results"] if r["bench"] == "full_solver" and r["status"] == "ok"]
    assert {r["grid_method"] for r in rows} == {"atomic", "raster"}
    for r in rows:
        assert {"integrate", "shape", "length", "collide", "sdf", "velocity", "friction"} <= set(r["passes_ms"])
        assert r["capsules"] == 8 and r["grid_resolution"] == 64 and r["sdf_resolution"] == 64
        assert r["nan_recoveries"] == 0


@pytest.mark.slow
def test_woodhouse_and_grid_rows(quick):
    rows = quick[0]["results"]
    wood = [r for r in rows if r["bench"] == "woodhouse" and r["status"] == "ok"]
    assert {(r["strands"], r["vertices"]) for r in wood} == {(242, 8), (242, 16)}
    for r in wood:
        cats = r["categories_ms"]
        assert _positive(cats["strand_dynamics"]) and _positive(cats["voxel_calculations"])
        assert cats["clear_voxels"] is not None and cats["clear_voxels"] >= 0
    grid = [r for r in rows if r["bench"] == "grid_friction" and r["status"] == "ok"]
    assert {(r["resolution"], r["method"]) for r in grid} == {(R, m) for R in (16, 32, 64)
                                                             for m in ("atomic", "raster")}
    for r in grid:
        for key in ("bounds", "splat", "normalise", "gather", "total", "voxel_calculations"):
            assert _positive(r[key]), (r["name"], key)


@pytest.mark.slow
def test_flip_rows_and_cpu_comparison(quick):
    rows = [r for r in quick[0]["results"] if r["bench"] == "flip" and r["status"] == "ok"]
    assert {r["resolution"] for r in rows} == {16, 32, 64}
    for r in rows:
        assert _positive(r["apply_ms"]["mean"]) and r["pcg_iterations"] >= 0
        assert set(r["stages_ms"]) >= set(sim_bench.FLIP_STAGES)
        assert sum(r["stage_share"].values()) == pytest.approx(1.0)
        if r["resolution"] in (16, 32):
            assert _positive(r["cpu_ms"]["median"]) and _positive(r["speedup"])
        else:
            assert r["cpu_ms"] is None            # quick mode skips the 64^3 CPU solve
    chen = [r for r in quick[0]["results"] if r["bench"] == "chen_shares" and r["status"] == "ok"]
    for r in chen:
        assert sum(r["share"].values()) == pytest.approx(1.0)
        assert r["share"]["volume_method"] > 0


@pytest.mark.slow
def test_targets_and_bandwidth(quick):
    result = quick[0]
    t = result["targets"]
    assert t["target_ms"] == 1.0 and isinstance(t["met"], bool)
    assert "full_solver_100k_x32_ms" in t
    assert t["full_solver_100k_x32_ms"] is None and t["met"] is False   # not measured in quick mode
    bw = result["bandwidth"]
    assert bw["kernel"] == "integrate" and bw["configuration"] == "1000x32"
    assert bw["bytes_per_step"] == 31_000 * 80 + 1_000 * 64
    assert _positive(bw["time_ms"]) and _positive(bw["achieved_GBps"])
    if bw["peak_GBps"] is None:
        assert bw["fraction_of_peak"] is None
    else:
        assert 0 < bw["fraction_of_peak"]


@pytest.mark.slow
def test_text_output(quick):
    text = sim_bench.format_text(quick[0])
    for title in ("DFTL core", "Full solver", "Woodhouse", "Grid friction", "FLIP volume", "Chen Table 4",
                  "DRAM bandwidth"):
        assert title in text
    assert "1000x32" in text


# ---------------------------------------------------------------------- pieces
def test_scalp_groom_shape_and_roots():
    g = sim_bench.scalp_groom(1000, 32)
    assert g.num_strands == 1000 and g.uniform_count == 32
    roots = g.points.reshape(1000, 32, 3)[:, 0].astype(np.float64)
    r = np.linalg.norm(roots - sim_bench.HEAD_CENTER, axis=1)
    assert np.allclose(r, sim_bench.HEAD_RADIUS, atol=1e-5)
    lengths = g.strand_lengths()
    assert np.allclose(lengths, sim_bench.STRAND_LENGTH, rtol=1e-4)


def test_head_mesh_is_closed_and_inside_the_scalp():
    from mane.sim.sdf import bake_sdf

    m = sim_bench.head_mesh()
    values, lo, h = bake_sdf(m.vertices, m.faces, resolution=24, padding=0.02)
    centre = np.round((sim_bench.HEAD_CENTER - lo) / h).astype(int)
    assert values[tuple(centre)] < 0
    assert values[0, 0, 0] > 0
    assert np.linalg.norm(m.vertices - sim_bench.HEAD_CENTER, axis=1).max() < sim_bench.HEAD_RADIUS


def test_peak_bandwidth_table():
    assert common.peak_bandwidth("NVIDIA H200/PCIe/SSE2") == (4.8e12, "H200")
    assert common.peak_bandwidth("NVIDIA H100 80GB HBM3/PCIe/SSE2") == (3.35e12, "H100")
    assert common.peak_bandwidth("NVIDIA H100 PCIe/PCIe/SSE2") == (2.0e12, "H100 PCIe")
    assert common.peak_bandwidth("llvmpipe (LLVM 15.0.6, 256 bits)") == (None, None)


def test_stats():
    s = common.stats([1.0, 2.0, 3.0, 4.0, 100.0])
    assert s["mean"] == pytest.approx(22.0) and s["median"] == 3.0 and s["n"] == 5
    assert 4.0 < s["p95"] <= 100.0
    assert common.stats([])["mean"] is None


def test_bench_help_lists_sim():
    from mane.app.cli import COMMANDS, build_parser

    assert COMMANDS["bench"][0] == "mane.app.bench"
    parser = build_parser("bench")
    args = parser.parse_args(["bench", "sim", "--quick", "--json"])
    assert args.target == "sim" and args.quick and args.json
    with pytest.raises(SystemExit):
        parser.parse_args(["bench", "sim", "--quick", "--full"])


def _fake_full_row(pipelined_ms: float, kernels: float, submit: float, alone_ms: float = 3.0) -> dict:
    s = common.stats([alone_ms] * 5)
    return {"bench": "full_solver", "name": "100000x32 atomic", "status": "ok", "reason": None,
            "strands": 100_000, "vertices": 32, "grid_method": "atomic", "step_ms": s, "wall_ms": s,
            "submit_ms": common.stats([submit] * 5), "pipelined_ms": pipelined_ms, "kernel_sum_ms": kernels,
            "step_source": "gpu-timer"}


def test_targets_from_a_100k_row():
    """The target is judged on steps back to back (pipelined), not on a step timed alone."""
    t = sim_bench._targets([_fake_full_row(0.8, 0.5, 0.3)], "default")
    assert t["full_solver_100k_x32_ms"] == pytest.approx(0.8) and t["met"] is True
    assert t["step_alone_ms"] == pytest.approx(3.0)
    assert t["likely_bound"] == "gpu" and t["met_by_kernels"] is True
    t = sim_bench._targets([_fake_full_row(2.0, 0.6, 1.9)], "default")
    assert t["met"] is False and t["met_by_kernels"] is True and t["likely_bound"].startswith("cpu")
    skipped = dict(_fake_full_row(1, 1, 1), status="skipped", reason="out of GPU memory: ...")
    t = sim_bench._targets([skipped], "default")
    assert t["full_solver_100k_x32_ms"] is None and t["met"] is False and "skipped" in t["note"]


def test_a_failing_configuration_is_recorded_and_skipped(gl):
    from mane.errors import GPUMemoryError

    bench = sim_bench.Bench(gl, "quick")
    with bench._guard("dftl_core", "huge", strands=10**9):
        raise GPUMemoryError("the simulation needs 1 TB")
    with bench._guard("dftl_core", "slow"):
        raise sim_bench.Skip("too slow")
    assert [(r["name"], r["status"]) for r in bench.rows] == [("huge", "skipped"), ("slow", "skipped")]
    assert "out of GPU memory" in bench.rows[0]["reason"] and bench.rows[0]["strands"] == 10**9
