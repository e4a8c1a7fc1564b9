"""``mane bench all --quick --out DIR``: it runs every benchmark target and writes every promised
file (a JSON per target, a CSV per table, every plot, the validation images, summary.md, all.json).

Nothing here checks speed or values: llvmpipe on a shared CPU is what the tests run on.
"""
from __future__ import annotations

import contextlib
import io
import json

import pytest

from mane.bench import all_bench, plots, quality

pytestmark = pytest.mark.gpu


@pytest.mark.slow
def test_bench_all_quick_writes_every_file(gl, tmp_path):
    from mane.app.cli import main

    out = tmp_path / "bench"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main(["bench", "all", "--quick", "--out", str(out)])
    assert rc == 0, stderr.getvalue()[-3000:]

    names = all_bench.targets()
    assert {"sim", "render", "oit", "quality", "limits"} <= set(names)
    promised = ["summary.md", "all.json", "scaling.csv", "scaling_summary.csv", "seed_figures.csv",
                "seed_figures.json", "limits_distance.csv"]
    for t in names:
        promised.append(f"{t}.json")
        promised += [f"{t}_{table}.csv" for table in all_bench.expected_tables(t)]
    promised += [f"plots/{p}.png" for p in plots.ALL_PLOTS]
    promised += [f"quality/{s}.png" for s in quality.SECTIONS]
    missing = [p for p in promised if not (out / p).is_file() or (out / p).stat().st_size == 0]
    assert not missing, missing

    index = json.loads((out / "all.json").read_text())
    assert set(promised) <= set(index["files"])
    assert all(index["targets"][t]["status"] == "ok" for t in names), index["targets"]
    assert not [k for k, v in index["plots"].items() if str(v).startswith("error")], index["plots"]
    for t in names:
        result = json.loads((out / f"{t}.json").read_text())
        assert result["meta"]["mode"] == "quick" and result["meta"]["renderer"]
    for p in promised:
        if p.endswith(".png"):
            assert (out / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", p
        if p.endswith(".csv"):
            assert (out / p).read_text().count("\n") >= 2, p      # a header and at least one row
    summary = (out / "summary.md").read_text()
    for heading in ("Woodhouse", "Chen", "Hunz", "Vulkan", "How time scales", "Quality"):
        assert heading in summary
    assert "mane bench all" in stderr.getvalue()                # the progress bar is on stderr
    check_limits(out, index, summary)


def _pass_ms(row, name):
    for key in ("gpu_passes_ms", "passes_ms"):
        v = ((row.get(key) or {}).get(name) or {}).get("mean")
        if v:
            return v
    return None


def _summary_row(summary: str, start: str) -> str:
    lines = [line for line in summary.splitlines() if line.startswith(start)]
    assert len(lines) == 1, (start, lines)
    return lines[0]


def check_limits(out, index, summary):
    """limits.json has every limit, positive, with its unit and method; summary.md's fractions
    are the JSON's own numbers divided (sim.json / render.json over limits.json)."""
    lim = json.loads((out / "limits.json").read_text())
    ok = [r for r in lim["results"] if r["status"] == "ok"]
    assert {r["bench"] for r in ok} == {"dram", "raster", "atomics"}
    for r in ok:
        assert r["value"] > 0 and r["value_median"] > 0 and r["time_ms"]["min"] > 0, r
        assert r["unit"] and r["method"], r
    peaks = lim["peaks"]
    assert peaks["dram_copy_GBps"] > 0
    for msaa in ("1", "4"):
        assert all(v > 0 for v in peaks["raster"][msaa].values())
    assert peaks["atomic_min_per_s"]["32"] > 0
    raster4 = next(r for r in ok if r["bench"] == "raster" and r["msaa"] == 4)
    assert raster4["samples"] == 4 * raster4["pixels"]        # pixel-aligned strips: every sample once

    section = summary.split("## Distance from the hardware limits", 1)[1].split("\n## ", 1)[0]
    rows = index["distance_from_limits"]
    # the solver: integrate bytes/s over the measured copy bandwidth
    bw = json.loads((out / "sim.json").read_text())["bandwidth"]
    want = bw["achieved_GBps"] / peaks["dram_copy_GBps"]
    assert next(r for r in rows if r["stage"] == "solver")["fraction"] == pytest.approx(want, rel=1e-12)
    assert f"**{100 * want:.1f}%**" in _summary_row(section, "| solver | integrate kernel |")
    # the hair pass, hardware (the target frame and the same with the other rasteriser: "auto"
    # picked one, llvmpipe's compute): 2 draws (depth pre-pass, shading) x segments x 2
    # triangles per second over the 4x MSAA peak
    render = json.loads((out / "render.json").read_text())["results"]
    rows = [r for r in render if r["bench"] in ("target", "target_rasterizer") and r["status"] == "ok"]
    assert rows[0]["bench"] == "target" and rows[0]["rasterizer"] == "compute"
    hw = next(r for r in rows if r["renderer_stats"].get("rasterizer", "hardware") == "hardware")
    assert hw["settings"]["depth_prepass"]
    want = 2 * 2 * hw["rendered_segments"] / (_pass_ms(hw, "hair") * 1e-3) / peaks["raster"]["4"]["triangles_per_s"]
    assert f"**{100 * want:.1f}%**" in _summary_row(section, f"| hair pass | hardware | {hw['name']},")
    # the compute rasteriser: its counted atomics per second of hair_raster over the atomicMin peak
    cp = next(r for r in rows if r.get("raster_atomics"))
    assert cp["renderer_stats"]["rasterizer"] == "compute"
    assert cp["sample_visits"] >= cp["sample_writes"] > 0 and cp["raster_atomics"] >= 2 * cp["sample_writes"]
    bits = str(cp["raster_atomic_bits"])
    want = cp["raster_atomics"] / (_pass_ms(cp, "hair_raster") * 1e-3) / peaks["atomic_min_per_s"][bits]
    line = _summary_row(section, f"| hair pass | compute ({bits}-bit visibility) | {cp['name']},")
    assert f"**{100 * want:.1f}%**" in line
    assert "sample_visits" not in hw and (out / "limits_distance.csv").read_text().count("\n") >= 3
