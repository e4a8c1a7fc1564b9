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


def test_bench_all_quick_writes_every_file(gl, tmp_path):
    from mane.app.cli import main

    out = tmp_path / "bench"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main(["bench", "all", "--quick", "--out", str(out)])
    assert rc == 0, stderr.getvalue()[-3000:]

    names = all_bench.targets()
    assert {"sim", "render", "oit", "quality"} <= set(names)
    promised = ["summary.md", "all.json", "scaling.csv", "scaling_summary.csv", "seed_figures.csv",
                "seed_figures.json"]
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
