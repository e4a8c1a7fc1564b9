"""Passes talk to the renderer through its public face: no module under render/passes or
render/oit reads or writes another object's private attribute (``r._targets``,
``getattr(r, "_geometry_version")``); their own (``self._x``, ``cls._x``) are theirs."""
from __future__ import annotations

import ast
from pathlib import Path

import mane.render

RENDER = Path(mane.render.__file__).resolve().parent
MODULES = sorted([*(RENDER / "passes").glob("*.py"), *(RENDER / "oit").glob("*.py")])
OWN = {"self", "cls"}


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def foreign_privates(source: str) -> list[str]:
    """'line: expression' for each private attribute reached through something other than self/cls."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            if not (isinstance(node.value, ast.Name) and node.value.id in OWN):
                out.append(f"{node.lineno}: {ast.unparse(node)}")
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id in ("getattr", "setattr", "hasattr", "delattr") and len(node.args) >= 2
              and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)
              and _private(node.args[1].value)
              and not (isinstance(node.args[0], ast.Name) and node.args[0].id in OWN)):
            out.append(f"{node.lineno}: {ast.unparse(node)}")
    return out


def test_no_pass_touches_another_objects_privates():
    found = [f"{p.relative_to(RENDER)}:{hit}" for p in MODULES for hit in foreign_privates(p.read_text())]
    assert not found, "use the renderer's public accessors:\n" + "\n".join(found)


def test_the_check_sees_private_access():
    src = ("x = r._targets['hdr']\nself.r._frames_dirty = True\ny = getattr(r, '_geometry_version', 0)\n"
           "ok = self._fbos\nok2 = cls._cache\nok3 = r.__class__\nok4 = getattr(self, '_slot')\n")
    assert sorted(h.split(":")[0] for h in foreign_privates(src)) == ["1", "2", "3"]
