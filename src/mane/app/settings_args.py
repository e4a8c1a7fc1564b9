"""``--set FIELD=VALUE`` and ``--config FILE.toml``: every settings field from the command line.

    mane render --set shadows=adsm --set shading_options.melanin=0.3,0.1 --set oit=k_buffer
    mane simulate default --set wind.velocity=2,0,0 --set solver.fold_gather=false
    mane render --simulate --set sim.friction=0.2 --config look.toml
    mane render --set list                      # every field, its range or choices, its help

A FIELD is a field of the command's settings (``render``: RenderSettings, ``sim``: SimSettings);
a nested group's field is ``wind.speed``-style (``wind.velocity``, ``solver.shape_pipeline``), a
table's entry ``shading_options.KEY``. Where a command takes both (``render --simulate``,
``view``, ``demo``) a name is looked up in both; ``render.`` or ``sim.`` in front picks one.
VALUE is read as the field's type: numbers, ``true``/``false``, a choice, numbers separated by
commas for tuples (``size=640x480`` too), ``none`` for an optional one. The TOML file holds the
same names as tables (``[render]``, ``[sim]``, ``[sim.wind]``) or dotted keys; one file can serve
every command (the tables of settings a command does not take are skipped). Order: the
hand-written flags, then ``--config``, then ``--set`` (the last wins). Every value is checked
against its declaration (mane.setting) before any work; an unknown name is a one-line error
with the closest names.
"""
from __future__ import annotations

import importlib
import sys

from ..errors import UsageError
from ..setting import apply, describe, flatten, lookup, names, read_toml, unknown

TARGETS = {"render": ("mane.render.settings", "RenderSettings"), "sim": ("mane.sim.settings", "SimSettings")}


def settings_class(target: str):
    module, name = TARGETS[target]
    return getattr(importlib.import_module(module), name)


def add_settings_arguments(parser, targets: tuple[str, ...]) -> None:
    """--set and --config for the settings ``targets`` ("render", "sim") of a command."""
    what = " and ".join({"render": "RenderSettings", "sim": "SimSettings"}[t] for t in targets)
    g = parser.add_argument_group(f"settings (every field of {what}; README: 'Settings')")
    g.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", dest="settings_set",
                   help="set any settings field (repeatable): shadows=adsm, wind.velocity=2,0,0, "
                        "shading_options.melanin=0.3,0.1; '--set list' lists them all")
    g.add_argument("--config", metavar="FILE.toml", dest="settings_config", default=None,
                   help="a TOML file of settings ([render], [sim] tables or dotted keys); --set wins over it")
    parser.set_defaults(_settings_targets=tuple(targets))


def listing(targets) -> str:
    """Every settable name of ``targets`` with what it accepts and its help (``--set list``)."""
    lines = []
    for t in targets:
        cls = settings_class(t)
        lines.append(f"[{t}] {cls.__name__}")
        for path in names(cls):
            f, _ = lookup(cls, path)
            m = f.metadata
            unit = f" {m['unit']}" if m["unit"] else ""
            lines.append(f"  {path}: {describe(m)}{unit}. {m['help']}")
    return "\n".join(lines)


def _resolve(path: str, targets) -> tuple[str, str]:
    """(target, path within it) for a name given on the command line or in a file."""
    head, _, rest = path.partition(".")
    if head in TARGETS and rest:
        if head not in targets:
            raise UsageError(f"{path}: this command takes {' and '.join(targets)} settings, not {head}")
        lookup(settings_class(head), rest)
        return head, rest
    found, known = [], []
    for t in targets:
        cls = settings_class(t)
        try:
            lookup(cls, path)
            found.append(t)
        except UsageError:
            known += names(cls)
    if len(found) > 1:
        raise UsageError(f"setting {path!r} is in both {' and '.join(found)}: write {found[0]}.{path} "
                         f"or {found[1]}.{path}")
    if not found:
        raise unknown(path, known)
    return found[0], path


def overrides(args) -> dict[str, list]:
    """target -> [(path, value)] from ``--config`` then ``--set`` (checked names, values as given)."""
    targets = getattr(args, "_settings_targets", ())
    out: dict[str, list] = {t: [] for t in targets}
    items: list = []
    config = getattr(args, "settings_config", None)
    if config:
        data = read_toml(config, "--config")
        # a file may hold every command's settings: the tables of targets this command lacks are skipped
        items += [(k, v) for k, v in flatten(data)
                  if not (k.split(".")[0] in TARGETS and k.split(".")[0] not in targets)]
    for text in getattr(args, "settings_set", None) or ():
        if text.strip() in ("list", "help"):
            print(listing(targets))
            raise SystemExit(0)
        name, eq, value = text.partition("=")
        if not eq or not name.strip():
            raise UsageError(f"--set takes FIELD=VALUE (e.g. shadows=adsm), got {text!r}")
        items.append((name.strip(), value))
    for path, value in items:
        target, inner = _resolve(path, targets)
        out[target].append((inner, value))
    return out


def apply_settings(settings, args, target: str):
    """``settings`` with the command line's ``--config`` and ``--set`` for ``target`` applied."""
    items = overrides(args).get(target, [])
    return apply(settings, items) if items else settings


def changed_fields(args, target: str) -> set[str]:
    """The top-level fields of ``target`` that ``--config``/``--set`` name."""
    return {path.split(".")[0] for path, _ in overrides(args).get(target, [])}


def check_settings(args) -> None:
    """Apply the command line's settings to the defaults once, so that a bad name or value is a
    one-line error before any work."""
    for target, items in overrides(args).items():
        if items:
            apply(settings_class(target)(), items)


if __name__ == "__main__":   # pragma: no cover - python -m mane.app.settings_args: the listing
    print(listing(sys.argv[1:] or tuple(TARGETS)))
