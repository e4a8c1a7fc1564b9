"""Every setting declared once (mane.setting) and, from that one declaration: validated, shown in
the viewer's panel, reachable from the command line (``--set``, ``--config``).

The walk covers every field of RenderSettings and SimSettings and of their nested groups
(SimSettings.wind: WindSettings, SimSettings.solver: SolverTuning). Bad values are made from each
field's own declaration (one past its range, a choice it lacks, a wrong length, an unknown key),
so a field added tomorrow is covered without touching this file.
"""
from __future__ import annotations

import dataclasses
import math

import pytest

from mane.errors import UsageError
from mane.render.settings import RenderSettings
from mane.setting import check, describe, names, setting
from mane.sim import SimSettings, SolverTuning, WindSettings

ROOTS = {"render": RenderSettings, "sim": SimSettings}


def walk(cls, prefix=""):
    """(dotted name, owning class, field) for every field, groups expanded (the group too)."""
    for f in dataclasses.fields(cls):
        yield prefix + f.name, cls, f
        if f.metadata.get("kind") == "group":
            yield from walk(f.metadata["group"], prefix + f.name + ".")


ALL = [(root, path, owner, f) for root, cls in ROOTS.items() for path, owner, f in walk(cls)]
IDS = [f"{root}.{path}" for root, path, _, _ in ALL]


def build(root: str, path: str, value):
    """The root settings with ``path`` set to ``value`` through the constructors (groups nested)."""
    cls = ROOTS[root]
    parts = path.split(".")
    if len(parts) == 1:
        return cls(**{path: value})
    group_field = next(f for f in dataclasses.fields(cls) if f.name == parts[0])
    return cls(**{parts[0]: group_field.metadata["group"](**{parts[1]: value})})


def bad_values(meta: dict) -> list:
    """Values the declaration refuses, made from the declaration alone."""
    kind = meta["kind"]
    if kind == "bool":
        return ["maybe", 2]
    if kind == "str":
        return ["no-such-choice", 5] if meta["choices"] else [5]
    if kind == "dict":
        return [{"no_such_key": 1}, "not a table"]
    if kind == "group":
        return [5]
    out = []
    lo, hi = meta["lo"], meta["hi"]
    if kind in ("int", "float"):
        if meta["choices"]:
            out.append(max(meta["choices"]) + 1)
        if hi is not None:
            out.append(hi if meta["hi_open"] else (hi + 1 if kind == "int" else hi * 1.5 + 1))
        if lo is not None:
            out.append(lo if meta["lo_open"] else (lo - 1 if kind == "int" else lo - abs(lo) * 0.5 - 1))
        if meta["multiple_of"]:
            out.append(lo + 1)
        out.append("seven")
        if kind == "float":
            out.append(math.nan)
        else:
            out.append(1.5 if lo is None or lo < 1.5 else lo + 0.5)
        return out
    # tuples
    if meta.get("each"):
        return [((0.0,) * (meta["each"] - 1),), "1,2"]
    n = meta["length"]
    out.append((0,) * (n + 1))
    if hi is not None:
        out.append((hi * 2 + 1,) * n)
    out.append((math.nan,) * n)
    return out


def good_value(path: str, meta: dict, default):
    """A value the declaration accepts, other than the default (cross-field rules respected)."""
    special = {"colliders": ((0.0, 1.6, 0.0, 0.1, 0.12, 0.1),), "dom_layers": (0.1, 0.3, 0.9)}
    if path in special:
        return special[path]
    kind = meta["kind"]
    if kind == "bool":
        return not default
    if meta["choices"]:
        return next(c for c in meta["choices"] if c != default)
    lo, hi = meta["lo"], meta["hi"]
    a = lo if lo is not None else -10.0
    b = hi if hi is not None else a + 10.0

    def at(t):
        x = a + (b - a) * t
        if kind == "int" or meta.get("item") == "int":
            x = int(round(x))
            if meta.get("multiple_of"):
                x -= x % meta["multiple_of"]
        return x

    if kind in ("int", "float"):
        x = at(0.25)
        return x if x != default else at(0.75)
    if kind == "tuple":
        return tuple(at(0.25 + 0.01 * i) for i in range(meta["length"]))
    raise AssertionError(path)


def as_text(value) -> str:
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, tuple) and value and isinstance(value[0], tuple):
        return ";".join(",".join(repr(x) for x in t) for t in value)
    if isinstance(value, tuple):
        return ",".join(repr(x) for x in value)
    return str(value)


# ---------------------------------------------------------------------------- declared, with help
@pytest.mark.parametrize("root, path, owner, f", ALL, ids=IDS)
def test_every_field_is_declared_with_help(root, path, owner, f):
    meta = f.metadata
    assert meta.get("kind"), f"{owner.__name__}.{f.name} has no declaration (mane.setting)"
    assert len(meta["help"]) >= 10, f"{owner.__name__}.{f.name}: help {meta['help']!r}"
    if meta["kind"] in ("int", "float") and not meta["choices"]:
        assert meta["lo"] is not None or meta["hi"] is not None, f"{path}: a number with no range"


# ---------------------------------------------------------------------------- validated
@pytest.mark.parametrize("root, path, owner, f", ALL, ids=IDS)
def test_every_field_is_validated(root, path, owner, f):
    meta = f.metadata
    assert build(root, path, getattr(owner(), f.name)) is not None      # the default passes
    bads = bad_values(meta)
    assert bads
    for bad in bads:
        with pytest.raises(UsageError) as exc:
            build(root, path, bad)
        msg = str(exc.value)
        assert "\n" not in msg and path in msg, (bad, msg)      # one line naming the field (wind.gust)
        if meta["kind"] not in ("dict", "group"):
            assert describe(meta) in msg, (bad, msg)            # and what it accepts


@pytest.mark.parametrize("root, path, owner, f", [a for a in ALL if a[3].metadata["kind"] in ("int", "float")],
                         ids=[i for a, i in zip(ALL, IDS) if a[3].metadata["kind"] in ("int", "float")])
def test_numbers_inside_the_range_pass_and_the_ends_are_as_declared(root, path, owner, f):
    meta = f.metadata
    value = good_value(path, meta, getattr(owner(), f.name))
    got = build(root, path, value)
    assert getattr(_leaf(got, path), f.name) == value
    for end, open_ in ((meta["lo"], meta["lo_open"]), (meta["hi"], meta["hi_open"])):
        if end is None or meta["choices"] or meta["multiple_of"]:
            continue
        if open_:
            with pytest.raises(UsageError):
                build(root, path, end)
        else:
            assert getattr(_leaf(build(root, path, end), path), f.name) == end


def _leaf(obj, path):
    for part in path.split(".")[:-1]:
        obj = getattr(obj, part)
    return obj


def test_check_names_the_field_value_and_range():
    m = dataclasses.fields(RenderSettings)[0].metadata    # size
    with pytest.raises(UsageError, match=r"^size must be 2 whole numbers in \[8, 8192\], got \(4, 4\)$"):
        check("size", m, (4, 4))
    with pytest.raises(UsageError, match=r"^grid_resolution must be a whole number in \[4, 256\], got 300$"):
        SimSettings(grid_resolution=300)
    with pytest.raises(UsageError, match=r"^solver.strand_group_size must be one of 32, 64, 128, 256, got 48$"):
        SolverTuning(strand_group_size=48)
    with pytest.raises(UsageError, match=r"has no key 'melanln' \(did you mean melanin\?\)"):
        RenderSettings(shading_options={"melanln": (1, 0)})


def test_a_setting_needs_help_and_a_reason_to_hide():
    with pytest.raises(TypeError):
        setting(1, lo=0, hi=2, help="")
    with pytest.raises(TypeError):
        setting(1, lo=0, hi=2, help="a number", panel=False)


def test_cross_field_checks_stay():
    with pytest.raises(UsageError, match="lod_end"):
        RenderSettings(lod=True, lod_start=3.0, lod_end=2.0)
    with pytest.raises(UsageError, match="dom_layers"):
        RenderSettings(dom_layers=(0.5, 0.2, 1.0))
    with pytest.raises(UsageError, match="oit_k"):
        RenderSettings(oit="k_buffer", oit_k=0)
    with pytest.raises(UsageError, match="gravity of"):
        SimSettings(gravity=(0.0, -900.0, -900.0))         # each component in range, the magnitude not
    with pytest.raises(UsageError, match="wind of up to"):
        WindSettings(velocity=(400.0, 0.0, 0.0), gust=1.0)


# ---------------------------------------------------------------------------- the viewer's panel
PANEL_CLASSES = (RenderSettings, SimSettings, WindSettings, SolverTuning)


@pytest.mark.parametrize("cls", PANEL_CLASSES, ids=[c.__name__ for c in PANEL_CLASSES])
def test_every_field_is_in_the_panel_or_hidden_with_a_reason(cls):
    from mane.viewer.panel import hidden, widget_plan

    plan = widget_plan(cls())
    why = hidden(cls)
    for f in dataclasses.fields(cls):
        meta = f.metadata
        if not meta["panel"]:
            assert f.name not in plan and len(why[f.name]) > 10, f.name
            continue
        w = plan[f.name]
        if meta["choices"]:
            assert w.kind == "combo" and tuple(w.choices) == tuple(meta["choices"]), (f.name, w)
        elif meta["kind"] == "bool":
            assert w.kind == "checkbox", (f.name, w)
        elif meta["kind"] == "group":
            assert w.kind == "dataclass", (f.name, w)
        elif meta["kind"] in ("int", "float"):
            assert w.kind in ("slider_int", "slider_float", "drag_int", "drag_float"), (f.name, w)
            # the widget never offers what validation refuses: its ends inside the declared range
            if meta["lo"] is not None:
                assert w.lo >= meta["lo"], (f.name, w, meta["lo"])
            if meta["hi"] is not None and w.kind.startswith("slider"):
                assert w.hi <= meta["hi"], (f.name, w, meta["hi"])
            if w.kind.startswith("slider"):
                assert (w.lo, w.hi) == tuple(meta["slider"] or (meta["lo"], meta["hi"])), (f.name, w)


def test_grid_resolution_panel_agrees_with_validation():
    from mane.viewer.panel import widget_plan

    w = widget_plan(SimSettings())["grid_resolution"]
    assert (w.lo, w.hi) == (4, 256)
    SimSettings(grid_resolution=int(w.hi))          # the slider's end is accepted
    with pytest.raises(UsageError):
        SimSettings(grid_resolution=int(w.hi) + 1)


# ---------------------------------------------------------------------------- the command line
def parse(command: str, *argv):
    from mane.app.cli import build_parser

    extra = ["default"] if command == "simulate" else []
    return build_parser(command).parse_args([command, *extra, *argv])


def settings_of(args):
    from mane.app.settings_args import overrides
    from mane.setting import apply

    got = overrides(args)
    return {t: apply(ROOTS[t](), items) for t, items in got.items()}


CLI = [(root, path, owner, f) for root, path, owner, f in ALL if f.metadata["kind"] != "group"]


@pytest.mark.parametrize("root, path, owner, f", CLI, ids=[f"{r}.{p}" for r, p, _, _ in CLI])
def test_every_field_is_reachable_with_set(root, path, owner, f):
    meta = f.metadata
    if meta["kind"] == "dict":
        key = "melanin" if root == "render" else "chunk"
        value, text = ((0.3, 0.1), "0.3,0.1") if root == "render" else (64, "64")
        for command, prefix in ((("render", ""), ("render", "")) if root == "render"
                                else (("simulate", ""), ("render", "sim."))):
            s = settings_of(parse(command, "--set", f"{prefix}{path}.{key}={text}"))[root]
            assert getattr(_leaf(s, path), f.name)[key] == value
        return
    value = good_value(path, meta, getattr(owner(), f.name))
    commands = [("render", "render.", "")] if root == "render" else [("simulate", "", ""), ("render", "sim.", "")]
    if root == "render":
        commands.append(("reference", "", ""))
    for command, prefix, _ in commands:
        s = settings_of(parse(command, "--set", f"{prefix}{path}={as_text(value)}"))[root]
        assert getattr(_leaf(s, path), f.name) == value, (command, path, value)


def test_bare_names_pick_their_settings_and_unknown_names_get_close_matches():
    s = settings_of(parse("render", "--set", "shadows=adsm", "--set", "friction=0.25",
                          "--set", "wind.velocity=2,0,0", "--set", "size=64x48"))
    assert s["render"].shadows == "adsm" and s["render"].size == (64, 48)
    assert s["sim"].friction == 0.25 and s["sim"].wind.velocity == (2.0, 0.0, 0.0)
    from mane.app.settings_args import overrides

    for argv, words in ((["--set", "shadws=adsm"], ["shadows"]), (["--set", "wind.sped=3"], ["wind."]),
                        (["--set", "nosuch"], ["FIELD=VALUE"])):
        with pytest.raises(UsageError) as exc:
            overrides(parse("render", *argv))
        assert "\n" not in str(exc.value) and all(w in str(exc.value) for w in words), str(exc.value)
    with pytest.raises(UsageError, match="takes render settings, not sim"):
        overrides(parse("reference", "--set", "sim.dt=0.01"))


def test_table_text_keys_keep_their_text():
    """A table key declared as text keeps the command line's text: "none" is a multiple-scattering
    mode (the help's own example), not None; other keys still read "none" as None. The renderer
    takes the result."""
    s = settings_of(parse("render", "--set", "shading_options.multiple_scattering=none",
                          "--set", "shading_options.tables=interpolated", "--set", "shading_options.sigma_a=none"))
    opts = s["render"].shading_options
    assert opts["multiple_scattering"] == "none" and opts["tables"] == "interpolated" and opts["sigma_a"] is None
    from mane.render.renderer import ShadingAdapter   # what the renderer builds from the options

    r = s["render"]
    assert ShadingAdapter(r.shading, r.hair_color, opts).settings.resolved_multiple_scattering == "none"


def test_config_file_tables_and_set_wins(tmp_path):
    cfg = tmp_path / "look.toml"
    cfg.write_text('[render]\nshadows = "adsm"\nsegments = 12\nshading_options = { melanin = [0.3, 0.1] }\n'
                   '[sim]\nfriction = 0.1\n[sim.wind]\nvelocity = [1.0, 0.0, 0.0]\n[sim.solver]\nfold_gather = false\n')
    s = settings_of(parse("render", "--config", str(cfg), "--set", "segments=20"))
    r, m = s["render"], s["sim"]
    assert (r.shadows, r.segments, r.shading_options["melanin"]) == ("adsm", 20, (0.3, 0.1))
    assert m.friction == 0.1 and m.wind.velocity == (1.0, 0.0, 0.0) and m.solver.fold_gather is False
    # the same file serves simulate, which has no render settings: its [render] table is skipped
    assert settings_of(parse("simulate", "--config", str(cfg)))["sim"].friction == 0.1
    bad = tmp_path / "bad.toml"
    bad.write_text("[render]\nsegments = 0\n")
    from mane.app.settings_args import check_settings

    with pytest.raises(UsageError, match=r"segments must be a whole number in \[1, 4096\], got 0"):
        check_settings(parse("render", "--config", str(bad)))


def test_set_list_names_every_field(capsys):
    from mane.app.settings_args import overrides

    with pytest.raises(SystemExit):
        overrides(parse("render", "--set", "list"))
    out = capsys.readouterr().out
    for cls in ROOTS.values():
        for name in names(cls):
            assert f"  {name}: " in out, name


def test_flags_are_checked_against_the_declared_ranges():
    from mane.app.checks import setting_number

    with pytest.raises(UsageError, match=r"--segments must be a whole number in \[1, 4096\]"):
        setting_number("--segments", RenderSettings, "segments", 5000)
    with pytest.raises(UsageError, match=r"--gust must be a finite number in \[0, 10\]"):
        setting_number("--gust", WindSettings, "gust", 11)
    assert setting_number("--dt", SimSettings, "dt", 0.01) == 0.01
