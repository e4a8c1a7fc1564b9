"""The first launch's compile bar (``progress.compiles_shown``): what it counts and when it shows."""
from __future__ import annotations

import pytest

from mane import phases, progress


def test_watching_sees_each_phase_as_it_ends():
    seen = []
    with phases.watching(lambda name, s, item: seen.append((name, item))):
        with phases.phase("compile", "a.comp"):
            pass
        phases.add("pass", 0.001, "hair")
    with phases.phase("compile", "b.comp"):   # after the block: not seen
        pass
    assert seen == [("compile", "a.comp"), ("pass", "hair")]
    assert phases._open == []


def test_compile_bar_counts_programs_on_a_terminal(monkeypatch, capsys):
    monkeypatch.setattr(progress, "enabled", lambda quiet=False: not quiet)
    with progress.compiles_shown(delay=0) as bar:
        for name in ("a.comp", "b.comp", "c.comp"):
            with phases.phase("compile", name):
                pass
        with phases.phase("sdf_bake"):   # not a compile
            pass
    assert bar.n == 3
    assert progress.COMPILE_DESC in capsys.readouterr().err
    assert phases._open == []


def test_compile_bar_is_silent_when_quiet_or_quick(monkeypatch, capsys):
    monkeypatch.setattr(progress, "enabled", lambda quiet=False: not quiet)
    with progress.compiles_shown(quiet=True) as bar:
        with phases.phase("compile", "a.comp"):
            pass
    assert bar is None
    with progress.compiles_shown(delay=60):   # a launch whose programs come from the cache
        with phases.phase("compile", "a.comp"):
            pass
    assert progress.COMPILE_DESC not in capsys.readouterr().err


@pytest.mark.gpu
def test_a_real_compile_ticks_the_bar(gl, monkeypatch, capsys):
    from pathlib import Path

    from mane.gpu import glsl

    monkeypatch.setattr(progress, "enabled", lambda quiet=False: not quiet)
    src = Path(glsl.__file__).parent / "fill_words.comp"
    with progress.compiles_shown(delay=0) as bar:
        glsl.compute_shader(gl, src, {"MANE_TEST_BAR": 7919})   # a define no other test uses: compiled here
        glsl.compute_shader(gl, src, {"MANE_TEST_BAR": 7919})   # this context's program: no compile
    assert bar.n == 1
    assert progress.COMPILE_DESC in capsys.readouterr().err
