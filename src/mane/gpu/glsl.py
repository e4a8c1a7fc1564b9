"""GLSL sources from files beside the Python that uses them.

A source may ``#include "other.glsl"`` (looked up beside the including file, then in
``mane/gpu/shaders``); each file is included once per program. ``defines`` are injected
after ``#version``, after a package's binding table (``register_bindings``: the buffer
bindings and image units of every program under a folder, as ``#define B_NAME 3`` lines). A line map from the assembled text back to the files (drivers differ
in how they honour ``#line``, so none is emitted) reports a compile error against the
original file and line:

    ShaderCompileError: src/mane/sim/integrate.comp:42: error: 'foo' undeclared
"""
from __future__ import annotations

import re
import time
import weakref
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ShaderCompileError, UsageError
from ..phases import phase

SHARED_SHADER_DIR = Path(__file__).with_name("shaders")
DEFAULT_VERSION = "#version 430 core"

_INCLUDE = re.compile(r'^\s*#\s*include\s+[<"]([^>"]+)[>"]\s*$')
_VERSION = re.compile(r"^\s*#\s*version\b")
_EXTENSION = re.compile(r"^\s*#\s*extension\b")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
# Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error C1008: ..."; others: "ERROR: 0:12: ..."
_ERROR_LOCATIONS = (
    re.compile(r"(?P<src>\d+):(?P<line>\d+)\(\d+\)"),
    re.compile(r"(?P<src>\d+)\((?P<line>\d+)\)"),
    re.compile(r"(?P<src>\d+):(?P<line>\d+)"),
)


@dataclass
class Source:
    """Preprocessed GLSL text, and for each of its lines the file and line it came from."""

    text: str
    files: list[Path] = field(default_factory=list)
    line_map: list[tuple[int, int]] = field(default_factory=list)  # text line - 1 -> (file, line)

    def origin(self, line: int) -> str:
        """'path:line' of the assembled text's 1-based ``line``."""
        if 1 <= line <= len(self.line_map):
            f, n = self.line_map[line - 1]
            return f"{self.files[f]}:{n}" if f >= 0 else f"<injected>:{n}"
        return f"<generated>:{line}"

    def locate(self, message: str) -> str:
        """Rewrite a driver's log so that each location names the original file and line."""
        out = []
        for line in message.splitlines():
            for pattern in _ERROR_LOCATIONS:
                m = pattern.search(line)
                if m:
                    line = line[: m.start()] + self.origin(int(m["line"])) + line[m.end():]
                    break
            out.append(line)
        return "\n".join(out)


def _format_define(name: str, value) -> str:
    if not _NAME.match(str(name)):
        raise UsageError(f"bad GLSL define name {name!r}")
    if value is True:
        value = 1
    elif value is False:
        value = 0
    return f"#define {name} {value}"


_IF = re.compile(r"^\s*#\s*if(n?def)?\b")
_ENDIF = re.compile(r"^\s*#\s*endif\b")


def _hoist_extensions(body: list[tuple[str, int, int]]) -> list[tuple[str, int, int]]:
    """Move unconditional ``#extension`` lines (an included file's too) up to the #version.

    GLSL refuses an #extension after the first declaration, so an include that needs one
    (``#extension GL_ARB_gpu_shader_int64 : require``) could not otherwise be included after
    code. Lines inside ``#if`` blocks stay where they are.
    """
    start = next((i for i, (t, _, _) in enumerate(body) if _VERSION.match(t)), -1) + 1
    hoisted, rest, depth = [], [], 0
    for i, item in enumerate(body):
        text = item[0]
        if i >= start and "#" in text:   # each pattern needs a '#': most lines skip the three
            if _IF.match(text):
                depth += 1
            elif _ENDIF.match(text):
                depth = max(0, depth - 1)
            elif depth == 0 and _EXTENSION.match(text):
                hoisted.append(item)
                continue
        rest.append(item)
    return rest[:start] + hoisted + rest[start:]


# folder -> {name: binding or unit}: a package's table (mane/render/bindings.py, ...)
_TABLES: dict[Path, dict[str, int]] = {}


_TABLE_NAME = re.compile(r"(B|IMG|TEX)_[A-Z0-9_]+")


def register_bindings(directory, namespace: dict) -> dict[str, int]:
    """Declare the binding table of the programs under ``directory``: the names of ``namespace``
    (a bindings module's ``globals()``) that read ``B_*`` (storage buffer bindings), ``IMG_*``
    (image units) or ``TEX_*`` (texture units) each become a ``#define`` in every source whose
    main file lies there (explicit defines override them). Returns the table."""
    table = {str(k): int(v) for k, v in namespace.items() if _TABLE_NAME.fullmatch(str(k))}
    _TABLES[Path(directory).resolve()] = table
    return table


def table_defines(path) -> dict[str, int]:
    """The binding-table defines a program whose main file is ``path`` gets."""
    path = Path(path).resolve()
    out: dict[str, int] = {}
    for folder, table in _TABLES.items():
        if folder in path.parents:
            out.update(table)
    return out


def load_source(path, defines: dict | None = None, include_dirs=()) -> Source:
    """Read ``path``, resolve its includes and inject its package's table and ``defines``."""
    path = Path(path)
    defines = {**table_defines(path), **(defines or {})}
    files: list[Path] = []
    included: set[Path] = set()
    dirs = [Path(d) for d in include_dirs] + [SHARED_SHADER_DIR]

    def expand(file: Path, stack: tuple[Path, ...]) -> list[tuple[str, int, int]]:
        file = file.resolve()
        if file in stack:
            chain = " -> ".join(p.name for p in stack + (file,))
            raise ShaderCompileError(f"{file}: circular #include ({chain})")
        if file in included:
            return []
        included.add(file)
        try:
            lines = file.read_text().splitlines()
        except OSError as exc:
            raise ShaderCompileError(f"cannot read shader {file}: {exc}") from None
        index = len(files)
        files.append(file)
        out: list[tuple[str, int, int]] = []
        for number, line in enumerate(lines, start=1):
            if "#" not in line:   # neither an include nor a #version: most lines, no pattern tried
                out.append((line, index, number))
                continue
            m = _INCLUDE.match(line)
            if not m:
                if index and _VERSION.match(line):
                    line = ""  # an included file's #version is the includer's
                elif "#include" in line:
                    # moderngl replaces `#include "x"` anywhere, comments too, from ctx.includes
                    line = line.replace("#include", "# include")
                out.append((line, index, number))
                continue
            name = m[1]
            candidates = [file.parent / name] + [d / name for d in dirs]
            target = next((c for c in candidates if c.is_file()), None)
            if target is None:
                raise ShaderCompileError(f"{file}:{number}: cannot find #include \"{name}\"")
            out.extend(expand(target, stack + (file,)))
        return out

    body = _hoist_extensions(expand(path, ()))
    # #version (and #extension lines) must come first; defines follow them.
    head: list[tuple[str, int, int]] = []
    i = 0
    while i < len(body) and (not body[i][0].strip() or body[i][0].lstrip().startswith("//")):
        i += 1
    if i < len(body) and _VERSION.match(body[i][0]):
        head.append(body[i])
        i += 1
    else:
        head.append((DEFAULT_VERSION, -1, 0))
        i = 0
    while i < len(body) and _EXTENSION.match(body[i][0]):
        head.append(body[i])
        i += 1
    head += [(_format_define(k, v), -1, n) for n, (k, v) in enumerate((defines or {}).items(), 1)]
    lines = head + body[i:]
    return Source("\n".join(t for t, _, _ in lines) + "\n", files, [(f, n) for _, f, n in lines])


# context -> {key: (file stamps, compiled object)}. Weak keys: a released and collected
# context takes its programs with it, and a new context that reuses its id() starts empty.
_cache: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _stamps(files) -> tuple:
    out = []
    for f in files:
        try:
            out.append((str(f), Path(f).stat().st_mtime_ns))
        except OSError:
            out.append((str(f), None))
    return tuple(out)


# How often a cached program looks at its files' modification times (seconds): edits to a
# shader are picked up while a viewer runs, without a stat() per file on every draw call.
RECHECK_SECONDS = 1.0


# (kind, paths, defines in the caller's order, include dirs, extra) -> _key's key: a call site
# asks with the same arguments every frame, and hashing them is cheaper than sorting and
# formatting the defines again
_keys: dict = {}


def _key(kind: str, paths, defines, include_dirs, extra=()) -> tuple:
    # Paths are used as given (callers pass absolute paths beside their module): resolving
    # them on every call cost more than the draw it served.
    try:
        d = defines or {}
        fast = (kind, tuple(paths), tuple(d), tuple(map(repr, d.values())), tuple(include_dirs), tuple(extra))
        key = _keys.get(fast)
    except TypeError:   # an unhashable path or argument: the slow key only
        fast = key = None
    if key is None:
        key = (kind, tuple(str(p) for p in paths),
               tuple(sorted(((str(k), repr(v)) for k, v in (defines or {}).items()))),
               tuple(str(d) for d in include_dirs), tuple(extra))
        if fast is not None:
            if len(_keys) > 4096:
                _keys.clear()
            _keys[fast] = key
    return key


def _cached(ctx, key):
    """The compiled object for ``key`` unless a file it was built from (includes too) changed."""
    entry = _cache.get(ctx, {}).get(key)
    if entry is None:
        return None
    stamps, obj, checked = entry
    now = time.monotonic()
    if now - checked < RECHECK_SECONDS:
        return obj
    if _stamps(f for f, _ in stamps) != stamps:
        return None
    _cache[ctx][key] = (stamps, obj, now)
    return obj


def _store(ctx, key, sources, obj):
    files = sorted({f for src in sources for f in src.files}, key=str)
    _cache.setdefault(ctx, {})[key] = (_stamps(files), obj, time.monotonic())
    return obj


def clear_cache(ctx=None) -> None:
    """Forget compiled programs (of one context, or all)."""
    if ctx is None:
        _cache.clear()
    else:
        _cache.pop(ctx, None)


def _compile(ctx, kind: str, sources: dict[str, Source], build):
    what = "+".join(Path(s.files[0]).name if s.files else stage for stage, s in sources.items())
    try:
        with phase("compile", what):
            return build()
    except Exception as exc:  # moderngl.Error carries the driver's log
        log = str(exc)
        for src in sources.values():
            log = src.locate(log)
        names = ", ".join(str(s.files[0]) for s in sources.values())
        raise ShaderCompileError(f"{kind} failed to build ({names}):\n{log}") from None


def compute_shader(ctx, path, defines: dict | None = None, include_dirs=(), instance=None):
    """A moderngl ComputeShader from a file, cached per context, file versions (includes too) and
    defines. ``instance`` (hashable): a program object of its own for the same source, whose
    uniforms no other caller writes (one light's maps among several keep their views' uniforms
    from frame to frame instead of writing them over another light's)."""
    key = _key("compute", [path], defines, include_dirs, () if instance is None else (instance,))
    shader = _cached(ctx, key)
    if shader is None:
        with phase("shader_source"):
            src = load_source(path, defines, include_dirs)
        shader = _store(ctx, key, [src], _compile(ctx, "compute shader", {"compute": src},
                                                  lambda: ctx.compute_shader(src.text)))
    return shader


def program(ctx, *, vertex, fragment=None, geometry=None, tess_control=None,
            tess_evaluation=None, defines: dict | None = None, include_dirs=(),
            varyings=(), cache: bool = True, instance=None):
    """A moderngl Program from stage files (paths); each stage gets the same defines;
    ``instance``: as compute_shader's."""
    stages = {
        "vertex_shader": vertex,
        "fragment_shader": fragment,
        "geometry_shader": geometry,
        "tess_control_shader": tess_control,
        "tess_evaluation_shader": tess_evaluation,
    }
    stages = {k: v for k, v in stages.items() if v is not None}
    key = _key("program", list(stages.values()), defines, include_dirs,
               (tuple(stages), tuple(varyings)) + (() if instance is None else (instance,)))
    if cache:
        prog = _cached(ctx, key)
        if prog is not None:
            return prog
    with phase("shader_source"):
        sources = {k: load_source(v, defines, include_dirs) for k, v in stages.items()}
    prog = _compile(ctx, "program", sources, lambda: ctx.program(
        **{k: s.text for k, s in sources.items()}, varyings=tuple(varyings)))
    if cache:
        _store(ctx, key, sources.values(), prog)
    return prog


class ProgramMemo:
    """A pass's compiled programs, each kept in a slot with what it was built from (``deps``,
    compared by identity first, then by equality): a frame then asks no define dict to be made
    and no cache key to be hashed (a hair shading program's defines are two dozen). Every
    RECHECK_SECONDS a slot goes back to ``build`` (compute_shader / program, whose cache
    notices an edited shader file), so a running viewer still picks up shader edits."""

    def __init__(self):
        self._slots: dict = {}

    def get(self, slot, deps: tuple, build):
        entry = self._slots.get(slot)
        now = time.monotonic()
        # a tuple compares its items by identity first, then by equality
        if entry is not None and now - entry[2] < RECHECK_SECONDS and entry[0] == deps:
            return entry[1]
        obj = build()
        self._slots[slot] = (deps, obj, now)
        return obj

    def clear(self) -> None:
        self._slots.clear()
