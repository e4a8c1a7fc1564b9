"""The house (docs/architecture.md): mane's import graph, read statically from the source with
``ast`` (function-local imports included), has no circle and no upward arrow between the floors
of ``LAYERS``; no package takes a private name from another; no source reads the tests' folder.

The checks run on a toy package first (``test_checks_find_*``): a check that cannot fail is a defect.
"""
from __future__ import annotations

import ast
from functools import lru_cache
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

# Floors of the house, bottom first. A module may import its own package and the packages of the
# floors below its own; packages on one floor do not import each other (sim and render sit side by
# side: a renderer reads a simulator's buffers through duck typing, never through an import).
# "" is the root package ``mane`` (mane.load, mane.render_image): a facade on top; any module may
# read its ``__version__`` (a literal, set before the root imports anything).
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "phases"),
    ("groom", "mesh", "progress", "setting", "disk_cache"),
    ("io", "grooming"),
    ("gpu",),
    ("sim", "render"),
    ("presets", "twins", "reference", "dataset", "warmup"),
    ("bench", "viewer"),
    ("app",),
    ("", "__main__"),
)
ROOT_NAMES_ANYONE_MAY_READ = {"__version__"}


# --------------------------------------------------------------------------- the graph
@lru_cache(maxsize=None)
def _parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def modules(src: Path, top: str = "mane") -> dict[str, tuple[Path, bool]]:
    """dotted name -> (file, is a package's __init__) for every .py under src/top."""
    out = {}
    for path in sorted((src / top).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        package = parts[-1] == "__init__"
        if package:
            parts = parts[:-1]
        out[".".join(parts)] = (path, package)
    return out


def import_edges(src: Path, top: str = "mane") -> list[tuple[str, str, str | None, int]]:
    """(importer, imported module, name taken from it or None, line) for every import of ``top``'s
    modules anywhere in a file (module level, functions, TYPE_CHECKING blocks). ``from a import b``
    is an edge to ``a.b`` when that is a module, else to ``a`` taking the name ``b``."""
    mods = modules(src, top)
    edges = []
    for name, (path, package) in mods.items():
        for node in ast.walk(_parse(path)):
            targets: list[tuple[str, str | None]] = []
            if isinstance(node, ast.Import):
                targets = [(a.name, None) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = name.split(".") if package else name.split(".")[:-1]
                    base = base[:len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    targets.append((sub, None) if sub in mods else (target, alias.name))
            for target, taken in targets:
                if target != top and not target.startswith(top + "."):
                    continue
                while target not in mods and "." in target:   # mane.x.y.attr -> the module mane.x.y
                    target = target.rsplit(".", 1)[0]
                if target != name:
                    edges.append((name, target, taken, node.lineno))
    return edges


def package_of(module: str) -> str:
    """mane.render.passes.base -> render; mane -> '' (the root)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def cycles(edges) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each as a list."""
    graph: dict[str, set[str]] = {}
    for a, b, _, _ in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def floor_of(package: str, layers=LAYERS) -> int | None:
    for i, floor in enumerate(layers):
        if package in floor:
            return i
    return None


def upward(edges, layers=LAYERS) -> list[str]:
    """Each import that does not go down the house (or stays in its package), as 'a -> b (line)'."""
    bad = []
    for a, b, taken, line in edges:
        pa, pb = package_of(a), package_of(b)
        if pa == pb:
            continue
        if pb == "" and taken in ROOT_NAMES_ANYONE_MAY_READ:
            continue
        fa, fb = floor_of(pa, layers), floor_of(pb, layers)
        if fa is None or fb is None:
            bad.append(f"{a} -> {b}: package {pa if fa is None else pb!r} is on no floor of LAYERS")
        elif fb >= fa:
            what = "beside" if fb == fa else "above"
            bad.append(f"{a} -> {b}{'.' + taken if taken else ''} (line {line}): {pb or 'mane'} is {what} {pa}")
    return bad


def private_imports(edges) -> list[str]:
    """Private names (``_x``, not dunders) taken from another package."""
    return [f"{a} takes {b}.{taken} (line {line})" for a, b, taken, line in edges
            if taken and taken.startswith("_") and not taken.startswith("__")
            and package_of(a) != package_of(b)]


def reads_tests(src: Path, top: str = "mane") -> list[str]:
    """String constants in code (docstrings and comments aside) naming the tests' folder."""
    bad = []
    for name, (path, _) in modules(src, top).items():
        tree = _parse(path)
        docstrings = {id(n.body[0].value) for n in ast.walk(tree)
                      if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                      and n.body and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
                text = node.value.replace("\\", "/")
                if text == "tests" or text.startswith("tests/") or "/tests/" in text:
                    bad.append(f"{name} (line {node.lineno}): {node.value!r}")
    return bad


# --------------------------------------------------------------------------- the checks on a toy house
def _toy(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        p = tmp_path / "toy" / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp_path


TOY_LAYERS = (("low",), ("mid_a", "mid_b"), ("top",))


def test_checks_find_a_circle_through_a_local_import(tmp_path):
    src = _toy(tmp_path, {"__init__.py": "", "low/__init__.py": "", "low/a.py": "from . import b\n",
                          "low/b.py": "def f():\n    from .a import g\n", "low/c.py": "from .a import x\n"})
    assert cycles(import_edges(src, "toy")) == [["toy.low.a", "toy.low.b"]]


def test_checks_find_upward_sideways_private_and_tests_paths(tmp_path):
    src = _toy(tmp_path, {
        "__init__.py": "__version__ = '1'\n",
        "low/__init__.py": "from .. import __version__\n",
        "low/x.py": "def f():\n    from ..top import run\n",          # up
        "mid_a/__init__.py": "from ..mid_b import thing\n",               # beside
        "mid_b/__init__.py": "from ..low.x import f, _hidden\n",          # down, but private
        "top/__init__.py": "from pathlib import Path\nP = Path(__file__).parents[2] / 'tests' / 'ref'\n",
    })
    edges = import_edges(src, "toy")
    bad = upward(edges, TOY_LAYERS)
    assert len(bad) == 2, bad
    assert "toy.low.x -> toy.top.run (line 2): top is above low" in bad
    assert any(b.startswith("toy.mid_a -> toy.mid_b.thing") and "beside" in b for b in bad)
    assert private_imports(edges) == ["toy.mid_b takes toy.low.x._hidden (line 1)"]
    assert reads_tests(src, "toy") == ["toy.top (line 2): 'tests'"]


# --------------------------------------------------------------------------- mane's house
@pytest.fixture(scope="module")
def edges():
    return import_edges(SRC)


def test_the_graph_sees_function_local_imports(edges):
    # mane.app.cli imports each sub-command only when it runs; the graph still has the arrow
    assert any(a == "mane.app.cli" and b.startswith("mane.app.") for a, b, _, _ in edges)
    assert len({a for a, _, _, _ in edges}) > 100


def test_no_import_circle(edges):
    found = cycles(edges)
    detail = []
    for comp in found:
        inside = set(comp)
        detail.append(" <-> ".join(comp) + ": " + "; ".join(
            f"{a} -> {b} (line {line})" for a, b, _, line in edges if a in inside and b in inside))
    assert not found, "import circles:\n" + "\n".join(detail)


def test_every_package_is_on_a_floor():
    packages = {package_of(m) for m in modules(SRC)}
    assert packages <= {p for floor in LAYERS for p in floor}, packages - {p for floor in LAYERS for p in floor}


def test_no_upward_arrow(edges):
    bad = upward(edges)
    assert not bad, "imports that go up or sideways in the house (docs/architecture.md):\n" + "\n".join(bad)


def test_no_private_name_from_another_package(edges):
    bad = private_imports(edges)
    assert not bad, "private names taken across packages:\n" + "\n".join(bad)


def test_source_does_not_read_the_tests_folder():
    bad = reads_tests(SRC)
    assert not bad, "src/ names the tests' folder:\n" + "\n".join(bad)


def test_one_default_groom():
    """Two different functions once shared the name ``default_groom``; one name, one function."""
    owners = []
    for name, (path, _) in modules(SRC).items():
        tree = _parse(path)
        owners += [name for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "default_groom"]
    assert len(owners) == 1, owners
