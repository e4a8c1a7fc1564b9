"""``python -m mane.bench.lod_compare``: the coverage LOD's frame against the full one, at a
tiny size (no timing claim): its files, and that the LOD thinned the strands and left the
picture close to the full one."""
from __future__ import annotations

import json

import pytest

from mane.bench import lod_compare

pytestmark = pytest.mark.gpu


def test_lod_compare_writes_images_and_metrics(gl, tmp_path):
    out = tmp_path / "lod"
    res = lod_compare.compare(gl, 300 * 8, (96, 64), out, lod_depth=2.0, frames=1, guides=300)
    for name in ("lod_on.png", "lod_off.png", "lod_diff.png", "lod_compare.json"):
        assert (out / name).stat().st_size > 0, name
    on, off = res["lod_on"], res["lod_off"]
    assert off["strands_expanded"] == off["strands_full"] == 2400
    assert 0 < on["strands_expanded"] < off["strands_expanded"]           # thinned
    hair = res["metrics_on_vs_off"]["hair"]
    assert res["hair_pixels"] > 50
    assert 0.8 < hair["luminance_ratio"] < 1.25                             # coverage conserved
    assert json.loads((out / "lod_compare.json").read_text())["lod_depth"] == 2.0
