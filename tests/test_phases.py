"""mane.phases: a start-up's wall-clock phases, summed per name in every open recording."""
from __future__ import annotations

import time

import pytest

from mane import phases


def test_phases_sum_per_name_and_nest():
    with phases.recording() as rec:
        for _ in range(3):
            with phases.phase("outer"):
                with phases.phase("inner"):
                    time.sleep(0.01)
    d = rec.as_dict()
    assert list(d) == ["inner", "outer"]           # the order they were first finished in
    assert d["inner"]["n"] == d["outer"]["n"] == 3
    assert 0.03 <= d["inner"]["s"] <= d["outer"]["s"]


def test_phases_without_a_recording_record_nothing():
    with phases.phase("lost"):
        pass
    with phases.recording() as rec:
        pass
    assert rec.as_dict() == {}


def test_two_recordings_both_see_a_phase():
    with phases.recording() as a:
        with phases.phase("x"):
            pass
        with phases.recording() as b:
            with phases.phase("y"):
                time.sleep(0.002)
    assert set(a.as_dict()) == {"x", "y"} and set(b.as_dict()) == {"y"}
    assert a.as_dict()["y"] == b.as_dict()["y"]


def test_items_name_each_occurrence():
    with phases.recording() as rec:
        with phases.phase("compile", "a.comp"):
            pass
        with phases.phase("compile", "b.vert+b.frag"):
            pass
        with phases.phase("other"):
            pass
    d = rec.as_dict()
    assert [name for name, _ in d["compile"]["items"]] == ["a.comp", "b.vert+b.frag"]
    assert sum(s for _, s in d["compile"]["items"]) == pytest.approx(d["compile"]["s"], abs=1e-5)
    assert "items" not in d["other"]


def test_a_compile_is_a_phase(gl):
    from mane.gpu import glsl
    from mane.sim.sdf import HERE

    glsl.clear_cache(gl)
    with phases.recording() as rec:
        glsl.compute_shader(gl, HERE / "sdf_collide.comp")
    d = rec.as_dict()["compile"]
    assert d["n"] == 1 and d["items"][0][0] == "sdf_collide.comp"


def test_add_counts_seconds_measured_elsewhere():
    with phases.recording() as a:
        phases.add("pass", 0.25, "hair")
        with phases.recording() as b:
            phases.add("pass", 0.5, "resolve")
    phases.add("lost", 1.0)   # none open: nothing
    assert a.as_dict()["pass"] == {"s": 0.75, "n": 2, "items": [["hair", 0.25], ["resolve", 0.5]]}
    assert b.as_dict() == {"pass": {"s": 0.5, "n": 1, "items": [["resolve", 0.5]]}}
