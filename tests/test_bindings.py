"""Buffer bindings and image units come from one table per package (render/bindings.py,
sim/bindings.py, gpu/bindings.py), never from numbers written in a shader, and no two names
one program uses together share a number."""
from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

import mane.gpu  # noqa: F401  (registers gpu's table)
import mane.render  # noqa: F401
import mane.sim  # noqa: F401
from mane.gpu.glsl import load_source, table_defines

SRC = Path(mane.gpu.__file__).resolve().parent.parent
SHADER_EXTS = (".glsl", ".comp", ".vert", ".frag", ".geom", ".tesc", ".tese")
STAGES = (".comp", ".vert", ".frag", ".geom", ".tesc", ".tese")
LITERAL = re.compile(r"binding\s*=\s*\d")
BINDING = re.compile(r"layout\s*\(([^)]*\bbinding\s*=\s*(\w+)[^)]*)\)\s*(.*)")
R = SRC / "render" / "passes"
O = SRC / "render" / "oit"
# the hardware hair program's stages (passes/base.py hair_program): each vertex path with each
# fragment stage a pass brings
INCLUDE_DIRS = (SRC / "render", R, SRC / "sim")   # what the programs' callers pass
HAIR_VERTEX = [[R / "hair.vert", R / "hair.tesc", R / "hair.tese", R / "hair.geom"],
               [R / "hair.vert", R / "hair.tesc", R / "hair.tese", R / "density_splat.geom"],
               [R / "hair_pull.vert"]]
HAIR_FRAGMENT = [R / "hair.frag", R / "hair_depth.frag", R / "osm.frag", R / "density_splat.frag",
                 O / "oit_hair.frag", O / "oit_hair450.frag"]


def shader_files():
    return sorted(p for p in SRC.rglob("*") if p.suffix in SHADER_EXTS)


def test_no_literal_binding_numbers_in_glsl():
    found = [f"{p.relative_to(SRC)}:{n}: {line.strip()}" for p in shader_files()
             for n, line in enumerate(p.read_text().splitlines(), 1) if LITERAL.search(line)]
    assert not found, "binding numbers belong in the package's bindings.py:\n" + "\n".join(found)


# ---------------------------------------------------------------- per program, branch by branch
_IF = re.compile(r"^\s*#\s*(if|ifdef|ifndef)\b(.*)")
_ELIF = re.compile(r"^\s*#\s*elif\b(.*)")
_ELSE = re.compile(r"^\s*#\s*else\b")
_ENDIF = re.compile(r"^\s*#\s*endif\b")
_VALUES = re.compile(r"^\s*\(?\s*(\w+)\s*==\s*(\d+)\s*\)?\s*$")


def _allowed(cond: str):
    """(macro, {values}) when ``cond`` is ``M == a || M == b ...``, else None."""
    terms = [_VALUES.match(t) for t in cond.split("||")]
    if not all(terms) or len({m[1] for m in terms}) != 1:
        return None
    return terms[0][1], {int(m[2]) for m in terms}


def declarations(files):
    """(name, kind, path) for each ``layout(binding = NAME)`` of the program made of ``files``
    (includes expanded); path: the branches it lies in, as (chain id, branch, condition)."""
    out = []
    chain_ids = itertools.count()
    for file in files:
        text = load_source(file, include_dirs=INCLUDE_DIRS).text
        stack: list[list] = []   # [chain id, branch index, condition]
        for line in text.splitlines():
            if m := _IF.match(line):
                cond = m[2].strip() if m[1] == "if" else None
                stack.append([next(chain_ids), 0, cond])
            elif m := _ELIF.match(line):
                stack[-1][1] += 1
                stack[-1][2] = m[1].strip()
            elif _ELSE.match(line):
                stack[-1][1] += 1
                stack[-1][2] = None
            elif _ENDIF.match(line):
                stack.pop()
            elif m := BINDING.search(line):
                kind = "buffer" if re.search(r"\bbuffer\b", m[3]) else "image"
                out.append((m[2], kind, tuple(tuple(s) for s in stack)))
    return out


def exclusive(a, b) -> bool:
    """Whether two branch paths can never both be compiled."""
    chains = {c: i for c, i, _ in a}
    if any(c in chains and chains[c] != i for c, i, _ in b):
        return True   # two branches of one #if chain
    for (_, _, ca), (_, _, cb) in itertools.product(a, b):
        va, vb = _allowed(ca or ""), _allowed(cb or "")
        if va and vb and va[0] == vb[0] and not va[1] & vb[1]:
            return True   # `#if M == 1` against `#if M == 2 || M == 3`
    return False


def clashes(files):
    table = table_defines(files[0])
    decls = [(n, k, p) for n, k, p in declarations(files) if n in table]
    bad = set()
    for (na, ka, pa), (nb, kb, pb) in itertools.combinations(decls, 2):
        if na != nb and ka == kb and table[na] == table[nb] and not exclusive(pa, pb):
            bad.add(f"{na} and {nb} ({ka} {table[na]})")
    return sorted(bad)


def programs():
    single = [[p] for p in shader_files() if p.suffix == ".comp"]
    hair = [v + [f] for v in HAIR_VERTEX for f in HAIR_FRAGMENT]
    return single + hair


@pytest.mark.parametrize("files", programs(), ids=lambda fs: "+".join(p.name for p in fs))
def test_no_two_bindings_of_a_program_share_a_number(files):
    assert not clashes(files), f"{[p.name for p in files]}: {clashes(files)}"


def test_every_binding_name_is_in_the_table():
    """A name no table declares would compile only where a caller passes it: those are the few
    per-program slots (the grid box and grid of the simulator's kernels)."""
    passed_by_caller = {"BOUNDS_BINDING", "GRID_BINDING"}
    missing = {f"{p.relative_to(SRC)}: {n}" for p in shader_files() for n, _, _ in declarations([p])
               if n not in table_defines(p) and n not in passed_by_caller}
    assert not missing, sorted(missing)


def test_the_clash_check_sees_a_clash(tmp_path, monkeypatch):
    """The check itself: two names with one number in one program fail, unless they lie in
    branches that exclude each other."""
    from mane.gpu import glsl

    monkeypatch.setitem(glsl._TABLES, tmp_path.resolve(), {"B_A": 3, "B_B": 3, "B_C": 4})
    bad = tmp_path / "bad.comp"
    bad.write_text("layout(std430, binding = B_A) buffer A { uint a[]; };\n"
                   "layout(std430, binding = B_B) buffer B { uint b[]; };\n")
    assert clashes([bad]) == ["B_A and B_B (buffer 3)"]
    ok = tmp_path / "ok.comp"
    ok.write_text("#if M == 1\nlayout(std430, binding = B_A) buffer A { uint a[]; };\n#endif\n"
                  "#if M == 2 || M == 3\nlayout(std430, binding = B_B) buffer B { uint b[]; };\n#endif\n"
                  "layout(r32f, binding = B_A) uniform image2D img;\n")   # images: their own units
    assert clashes([ok]) == []
    ok.write_text("#ifdef X\nlayout(std430, binding = B_A) buffer A { uint a[]; };\n#else\n"
                  "layout(std430, binding = B_B) buffer B { uint b[]; };\n#endif\n"
                  "layout(std430, binding = B_C) buffer C { uint c[]; };\n")
    assert clashes([ok]) == []
    assert "#define B_A 3" in load_source(ok).text
