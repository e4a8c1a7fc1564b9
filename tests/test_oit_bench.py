"""``mane bench oit``: a tiny configuration end to end (JSON shape, bytes, text tables) and the
memory table beside Hunz's numbers."""
from __future__ import annotations

import json

import pytest

from mane.bench import oit_bench

pytestmark = pytest.mark.gpu


@pytest.fixture
def tiny(monkeypatch):
    cfg = dict(oit_bench.MODE_CONFIG["quick"], strands=64, sizes=[(48, 64)], shadows=("none",), warmup=2, frames=2,
               memory_sizes=[(48, 64)], config_budget_s=30.0)
    monkeypatch.setitem(oit_bench.MODE_CONFIG, "quick", cfg)
    return cfg


@pytest.mark.slow
def test_bench_runs_every_method_and_reports_bytes(gl, tiny):
    result = oit_bench.run(gl, "quick")
    json.dumps(result, default=str, allow_nan=False)
    rows = result["methods"]
    labels = {r["method"] for r in rows}
    assert {"none", "sorted_blending", "random_subsets", "a_buffer", "dbk_buffer", "shortcut"} <= labels
    assert any(m.startswith("k_buffer/") for m in labels)
    ok = [r for r in rows if r["status"] == "ok"]
    assert len(ok) == len(rows), [r["reason"] for r in rows if r["status"] != "ok"]
    for r in ok:
        assert r["frame_ms"]["mean"] > 0
        assert (r["oit_bytes"] > 0) == (r["method"] != "none")
    # both rasterizers: the compute forms of the A-buffer, K-buffer, DBK-buffer, ShortCut (and
    # the opaque "none"), each row saying which drew it
    drawn = {(r["method"].split("/")[0], r["rasterizer"]) for r in rows}
    for m in ("a_buffer", "k_buffer", "dbk_buffer", "shortcut", "none"):
        assert (m, "compute") in drawn and (m, "hardware") in drawn, m
    assert ("sorted_blending", "compute") not in drawn
    assert {r["rasterizer"] for r in result["target"]["rows"]} == {"compute", "hardware"}
    assert result["memory"] and result["target"]["rows"]
    text = oit_bench.format_text(result)
    assert "Hunz Fig. 42" in text and "dbk_buffer" in text and "target" in text
    assert "rasterizer" in text and "compute/atomic" in text


def test_memory_table_puts_hunz_beside_the_measured_bytes(gl):
    b = oit_bench.Bench(gl, "default")
    b.rows = [{"method": "a_buffer", "size": [656, 861], "groom": "straight", "shadows": "none", "status": "ok",
               "oit_bytes": 100 * 2**20, "oit_fragments_per_pixel": 12.0},
              {"method": "a_buffer", "size": [1920, 1080], "groom": "straight", "shadows": "none", "status": "ok",
               "oit_bytes": 300 * 2**20}]
    mem = {(m["method"], tuple(m["size"])): m for m in b.memory()}
    assert mem[("a_buffer", (656, 861))]["hunz_mib"] == pytest.approx(150.46)
    assert mem[("a_buffer", (656, 861))]["oit_mib"] == pytest.approx(100.0)
    assert mem[("a_buffer", (1920, 1080))]["hunz_mib"] is None


def test_bench_target_is_registered():
    from mane.app.bench import TARGETS

    assert TARGETS["oit"][0] == "mane.bench.oit_bench"
