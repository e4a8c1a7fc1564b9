"""One declaration per setting: a dataclass field's range, choices, unit and help, in its metadata.

    @dataclass(frozen=True)
    class S:
        segments: int = setting(32, lo=1, hi=4096, help="rendered segments per strand")
        shadows: str = setting("adsm", choices=("none", "adsm"), help="shadow method")

        def __post_init__(self):
            validate(self)            # generated from the metadata; cross-field checks by hand after

Everything else that needs to know a setting reads it from here: the validation (``validate``:
one-line ``UsageError`` naming the field, its value and what is allowed), the viewer's panel
(``mane.viewer.panel``: sliders and combos), the command line's ``--set FIELD=VALUE`` and
``--config FILE.toml`` (``parse_text``, ``apply``; ``mane.app.settings_args``) and the argument
checks of hand-written flags (``mane.app.checks.setting_number``).

Kinds, from the default (or ``factory``): bool, int, float, str, tuple (of ``length`` numbers,
or of ``each``-number tuples when ``each`` is given; ``optional``: None allowed), dict (``keys``:
the allowed keys, a tuple or a "module:attribute" callable's name giving them) and group (a nested
settings dataclass, ``factory``). Ranges are ``lo``..``hi`` (closed unless ``lo_open`` /
``hi_open``); numbers and tuple items must be finite. ``slider``: a narrower (lo, hi) for the
panel's slider inside a wide range; ``panel=False`` hides a field from the panel, ``reason``
says why (required then).
"""
from __future__ import annotations

import dataclasses
import difflib
import importlib
import math
from dataclasses import MISSING, field, fields, is_dataclass, replace

from .errors import UsageError

KINDS = ("bool", "int", "float", "str", "tuple", "dict", "group")


def setting(default=MISSING, *, factory=MISSING, lo=None, hi=None, lo_open: bool = False, hi_open: bool = False,
            choices=None, length: int | None = None, each: int | None = None, optional: bool = False, keys=None,
            multiple_of: int | None = None, unit: str = "", help: str, panel: bool = True, reason: str = "",
            slider=None, format: str | None = None):
    """A dataclass field whose metadata declares the setting (see the module doc)."""
    if not help or not help.strip():
        raise TypeError("a setting needs its help")
    if not panel and not reason:
        raise TypeError("a setting hidden from the panel needs the reason")
    if factory is not MISSING:
        sample = factory()
        kind = "group" if is_dataclass(sample) else "dict" if isinstance(sample, dict) else None
        if kind is None:
            raise TypeError(f"factory must make a dict or a dataclass, got {sample!r}")
    else:
        sample = default
        kind = ("bool" if isinstance(default, bool) else "int" if isinstance(default, int)
                else "float" if isinstance(default, float) else "str" if isinstance(default, str)
                else "tuple" if isinstance(default, tuple) or (default is None and (length or each)) else None)
        if kind is None:
            raise TypeError(f"cannot tell the kind of setting from its default {default!r}")
    item = None
    if kind == "tuple":
        if length is None and each is None and sample is not None:
            length = len(sample)
        flat = [x for t in sample for x in t] if each and sample else list(sample or ())
        item = "int" if flat and all(isinstance(x, int) and not isinstance(x, bool) for x in flat) else "float"
    meta = {"kind": kind, "item": item, "lo": lo, "hi": hi, "lo_open": lo_open, "hi_open": hi_open,
            "choices": tuple(choices) if choices is not None else None, "length": length, "each": each,
            "optional": optional or default is None, "keys": keys, "multiple_of": multiple_of, "unit": unit,
            "help": " ".join(help.split()), "panel": panel, "reason": reason, "slider": slider,
            "group": type(sample) if kind == "group" else None}
    if format is not None:
        meta["format"] = format                # the panel's number format
    if slider is not None:
        meta["range"] = tuple(slider)          # the panel's slider (mane.viewer.panel reads "range")
    elif lo is not None and hi is not None and kind in ("int", "float"):
        meta["range"] = (lo, hi)
    if factory is not MISSING:
        return field(default_factory=factory, metadata=meta)
    return field(default=default, metadata=meta)


_DECLARED: dict = {}


def declared(cls) -> list[dataclasses.Field]:
    """The fields of a settings dataclass that carry a declaration (cached per class)."""
    found = _DECLARED.get(cls)
    if found is None:
        found = _DECLARED[cls] = [f for f in fields(cls) if "kind" in f.metadata]
    return found


def describe(meta: dict) -> str:
    """What a setting accepts, in words: "a whole number in [1, 4096]", "a finite number in [0, 1]",
    "one of a, b"."""
    kind = meta["kind"]
    if meta.get("choices") is not None:
        return "one of " + ", ".join(str(c) for c in meta["choices"])
    if kind == "bool":
        return "true or false"
    if kind == "str":
        return "a string"
    if kind == "dict":
        keys = _keys(meta)
        return "a table" + (f" of {', '.join(keys)}" if keys else "")
    if kind == "group":
        return f"a {meta['group'].__name__}"
    rng = _range_text(meta)
    if kind in ("int", "float"):
        what = "a whole number" if kind == "int" else "a finite number"
        extra = f", a multiple of {meta['multiple_of']}" if meta.get("multiple_of") else ""
        return f"{what} in {rng}{extra}" if rng else what + extra
    # tuple
    item = "whole numbers" if meta["item"] == "int" else "finite numbers"
    inside = f" in {rng}" if rng else ""
    if meta.get("each"):
        text = f"a list of ({meta['each']} {item}){inside}"
    else:
        text = f"{meta['length']} {item}{inside}"
    return text + (" or none" if meta["optional"] else "")


def _range_text(meta: dict) -> str:
    lo, hi = meta.get("lo"), meta.get("hi")
    if lo is None and hi is None:
        return ""
    return (f"{'(' if meta.get('lo_open') else '['}{'-inf' if lo is None else f'{lo:g}'}, "
            f"{'inf' if hi is None else f'{hi:g}'}{')' if meta.get('hi_open') else ']'}")


def _key_types(meta: dict) -> dict:
    """A table's keys -> their declared types ("" where the declaration names none): ``keys`` is
    a sequence of names or a name -> type mapping, or "module:function" giving one."""
    keys = meta.get("keys")
    if isinstance(keys, str):           # "module:function": resolved when first needed
        mod, name = keys.split(":")
        keys = getattr(importlib.import_module(mod), name)()
    if isinstance(keys, dict):
        return dict(keys)
    return {k: "" for k in keys} if keys else {}


def _keys(meta: dict) -> tuple:
    return tuple(_key_types(meta))


def _in_range(v: float, meta: dict) -> bool:
    lo, hi = meta.get("lo"), meta.get("hi")
    if lo is not None and (v <= lo if meta.get("lo_open") else v < lo):
        return False
    if hi is not None and (v >= hi if meta.get("hi_open") else v > hi):
        return False
    return True


def _number(v, integer: bool):
    """``v`` as a finite int/float, or None when it is not one."""
    if type(v) is float and not integer:       # the common case, fast
        return v if math.isfinite(v) else None
    if isinstance(v, bool) or isinstance(v, (str, bytes)) or v is None:
        return None
    if integer and hasattr(v, "__index__"):     # int, numpy integers: exact, however large
        return int(v.__index__())
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    if not math.isfinite(x):
        return None
    if integer:
        return int(x) if x == int(x) else None
    return x


def check(name: str, meta: dict, value):
    """``value`` coerced to the setting's kind (ints, floats, tuples), or a one-line UsageError
    naming ``name``, the value and what is allowed."""
    kind = meta["kind"]

    def bad():
        return UsageError(f"{name} must be {describe(meta)}, got {value!r}")

    if kind == "bool":
        if isinstance(value, bool) or type(value).__name__ == "bool_":
            return bool(value)
        if isinstance(value, int) and value in (0, 1):
            return bool(value)
        raise bad()
    if kind in ("int", "float"):
        x = _number(value, kind == "int")
        if x is None or not _in_range(x, meta):
            raise bad()
        if meta.get("choices") is not None and x not in meta["choices"]:
            raise bad()
        if meta.get("multiple_of") and x % meta["multiple_of"]:
            raise bad()
        return x
    if kind == "str":
        if not isinstance(value, str) or (meta.get("choices") is not None and value not in meta["choices"]):
            raise bad()
        return value
    if kind == "dict":
        if not isinstance(value, dict):
            raise bad()
        keys = _keys(meta)
        unknown = [k for k in value if keys and k not in keys]
        if unknown:
            raise UsageError(f"{name} has no key {unknown[0]!r}{_did_you_mean(str(unknown[0]), keys)}; "
                             f"keys: {', '.join(keys)}")
        return value
    if kind == "group":
        cls = meta["group"]
        if isinstance(value, dict):
            try:
                return cls(**value)
            except TypeError as exc:
                raise UsageError(f"{name}: {exc}") from None
        if not isinstance(value, cls):
            raise bad()
        return value
    # tuple
    if value is None:
        if meta["optional"]:
            return None
        raise bad()
    integer = meta["item"] == "int"

    def numbers(v, length: int) -> tuple:
        """``v`` as ``length`` numbers in range, or bad()."""
        if isinstance(v, (str, bytes, dict)):
            raise bad()
        try:
            xs = [_number(x, integer) for x in v]
        except TypeError:
            raise bad() from None
        if len(xs) != length or any(x is None or not _in_range(x, meta) for x in xs):
            raise bad()
        return tuple(xs)

    if meta.get("each"):
        if isinstance(value, (str, bytes, dict)):
            raise bad()
        try:
            items = list(value)
        except TypeError:
            raise bad() from None
        return tuple(numbers(t, meta["each"]) for t in items)
    return numbers(value, meta["length"])


_PASSED: set = set()
"""(field, type, value, item types) that passed unchanged: a settings object is rebuilt by every
``replace`` (the viewer: once a frame), and most of its values were checked before."""


def validate(obj, prefix: str = "") -> None:
    """Check and coerce every declared field of the frozen dataclass ``obj`` (from ``__post_init__``)."""
    for f in declared(type(obj)):
        value = getattr(obj, f.name)
        kind = f.metadata["kind"]
        key = None
        if kind in ("bool", "int", "float", "str") or (kind == "tuple" and not f.metadata["each"]):
            key = (id(f), type(value), value, tuple(map(type, value)) if type(value) is tuple else None)
            try:
                if key in _PASSED:
                    continue
            except TypeError:       # an unhashable value: checked (and refused) below
                key = None
        new = check(prefix + f.name, f.metadata, value)
        if new is not value:
            object.__setattr__(obj, f.name, new)
        elif key is not None:
            if len(_PASSED) > 50_000:
                _PASSED.clear()
            _PASSED.add(key)


# ---------------------------------------------------------------------------- text and paths
TRUE = ("true", "yes", "on", "1")
FALSE = ("false", "no", "off", "0")


def parse_text(name: str, meta: dict, text: str):
    """A command line's text as the setting's kind (checked later by the class)."""
    kind = meta["kind"]
    t = text.strip()
    if kind == "bool":
        if t.lower() in TRUE:
            return True
        if t.lower() in FALSE:
            return False
        raise UsageError(f"{name} must be true or false, got {text!r}")
    if kind in ("int", "float"):
        try:
            x = float(t)
        except ValueError:
            raise UsageError(f"{name} must be {describe(meta)}, got {text!r}") from None
        return int(x) if kind == "int" and math.isfinite(x) and x == int(x) else x
    if kind == "str":
        return t
    if kind == "tuple":
        if meta["optional"] and t.lower() in ("none", "null", ""):
            return None
        if meta.get("each"):
            groups = [g for g in t.replace(" ", "").split(";") if g]
            return tuple(tuple(_items(name, meta, g)) for g in groups)
        return tuple(_items(name, meta, t))
    if kind == "dict":
        raise UsageError(f"{name} is a table: give {name}.KEY=VALUE")
    raise UsageError(f"{name} is a group: give {name}.FIELD=VALUE")


def _items(name: str, meta: dict, text: str) -> list:
    parts = [p for p in text.replace("x", ",").split(",")] if meta["item"] == "int" else text.split(",")
    try:
        return [float(p) if meta["item"] == "float" else int(float(p)) for p in parts]
    except ValueError:
        raise UsageError(f"{name} must be {describe(meta)} separated by commas, got {text!r}") from None


def literal(text: str):
    """A table entry's text (``shading_options.melanin=0.3,0.1``): true/false, a number, numbers
    separated by commas, or the text itself."""
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    if t.lower() == "none":
        return None
    try:
        if "," in t:
            return tuple(float(p) for p in t.split(","))
        x = float(t)
        return int(x) if math.isfinite(x) and x == int(x) and "." not in t and "e" not in t.lower() else x
    except ValueError:
        return t


def names(cls, prefix: str = "") -> list[str]:
    """Every settable dotted name of a settings class (groups expanded)."""
    out = []
    for f in declared(cls):
        if f.metadata["kind"] == "group":
            out += names(f.metadata["group"], prefix + f.name + ".")
        else:
            out.append(prefix + f.name)
    return out


def _did_you_mean(name: str, known) -> str:
    close = difflib.get_close_matches(name, list(known), n=3, cutoff=0.6)
    return f" (did you mean {', '.join(close)}?)" if close else ""


def unknown(name: str, known, what: str = "setting") -> UsageError:
    """The one-line error of an unknown name, with the closest known ones."""
    close = difflib.get_close_matches(name, list(known), n=3, cutoff=0.6)
    if not close:   # a bare field name of a group: "speed" for "wind.speed"
        close = [k for k in known if k.rsplit(".", 1)[-1] == name.rsplit(".", 1)[-1]][:3]
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    return UsageError(f"unknown {what} {name!r}{hint}")


def lookup(cls, path: str) -> tuple[dataclasses.Field, str]:
    """(the field, its dotted path) a path names; for tables the field of the table."""
    parts = path.split(".")
    current = cls
    for i, part in enumerate(parts):
        fmap = {f.name: f for f in declared(current)}
        f = fmap.get(part)
        if f is None:
            raise unknown(path, names(cls))
        kind = f.metadata["kind"]
        if kind == "group" and i < len(parts) - 1:
            current = f.metadata["group"]
            continue
        if kind == "dict" and i == len(parts) - 2:
            return f, ".".join(parts[:i + 1])
        if i != len(parts) - 1:
            raise unknown(path, names(cls))
        return f, path
    raise unknown(path, names(cls))


def apply(obj, items, root=None):
    """``obj`` with ``items`` ((dotted path, value) pairs) set, all in one ``replace`` per level (so
    that fields checked together, lod_start and lod_end, are set together); a ``str`` value for a
    setting of another kind is parsed from text (``parse_text``). Nested groups are replaced
    through, tables (dict settings) take ``table.KEY`` entries; the class validates the result."""
    if root is None:          # every name checked first, so that an error names the whole path
        root = type(obj)
        for path, value in items:
            if not (isinstance(value, dict) and lookup(root, path)[0].metadata["kind"] == "group"):
                lookup(root, path)
    fmap = {f.name: f for f in declared(type(obj))}
    changes: dict = {}
    subs: dict = {}
    for path, value in items:
        parts = path.split(".")
        f = fmap.get(parts[0])
        if f is None:
            raise unknown(path, names(root))
        meta = f.metadata
        if len(parts) > 1:
            if meta["kind"] == "group":
                subs.setdefault(f.name, []).append((".".join(parts[1:]), value))
            elif meta["kind"] == "dict" and len(parts) == 2:
                table = dict(changes.get(f.name, getattr(obj, f.name)))
                text = isinstance(value, str) and _key_types(meta).get(parts[1]) == "str"
                table[parts[1]] = (value.strip() if text else literal(value) if isinstance(value, str)
                                   else tuple(value) if isinstance(value, list) else value)
                changes[f.name] = table
            else:
                raise unknown(path, names(root))
            continue
        if meta["kind"] == "group" and isinstance(value, dict):
            subs.setdefault(f.name, []).extend(_flatten(value))
            continue
        if isinstance(value, str) and meta["kind"] != "str":
            value = parse_text(path, meta, value)
        elif isinstance(value, list):
            value = tuple(tuple(v) if isinstance(v, list) else v for v in value)
        changes[f.name] = value
    for name, sub in subs.items():
        changes[name] = apply(changes.get(name, getattr(obj, name)), sub, root)
    return replace(obj, **changes) if changes else obj


def _flatten(table: dict, prefix: str = "") -> list:
    out = []
    for k, v in table.items():
        if isinstance(v, dict):
            out += _flatten(v, f"{prefix}{k}.")
        else:
            out.append((prefix + k, v))
    return out


def flatten(table: dict) -> list:
    """A TOML table of settings as (dotted path, value) pairs (nested tables become paths)."""
    return _flatten(table)


def read_toml(path, what: str) -> dict:
    """A TOML file of settings (``--config``, a data set's spec), or a one-line UsageError
    starting with ``what``."""
    import tomllib

    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise UsageError(f"{what}: no file {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{what}: cannot read {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{what}: {path} is not valid TOML: {exc}") from None
