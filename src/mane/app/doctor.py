"""``mane doctor``: what OpenGL this machine gives mane, and what mane can do with it.

Prints the renderer, version, software or GPU, the extensions and limits that matter,
GPU memory and the feature table, then runs a tiny compute shader as a self-test
(``mane.gpu.microbench.selftest``).
With ``--json``: one JSON object. Without a usable OpenGL 4.3 (no libEGL, macOS's 4.1)
it says what is missing and how to get it, and exits 1.
"""
from __future__ import annotations

import ctypes.util
import json
import platform
import sys

HELP = "report the OpenGL renderer, limits, extensions and available features"

# How to get an OpenGL 4.3 core context through EGL, per situation.
FIX_DEBIAN = ("Debian/Ubuntu without a GPU: sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri "
              "(Mesa's llvmpipe gives OpenGL 4.5 on the CPU)")
FIX_NVIDIA = "with an NVIDIA GPU: install the NVIDIA driver (it brings libEGL_nvidia) and libegl1 (glvnd)"
FIX_MACOS = ("macOS stops at OpenGL 4.1 (no compute shaders): mane cannot run there; "
             "use a Linux machine or a Linux VM/container with Mesa")


def add_arguments(parser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    parser.add_argument("--no-selftest", action="store_true",
                        help="skip the small compute-shader check")


# --------------------------------------------------------------------------- diagnosis

def _library_versions() -> dict:
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for mod in ("mane", "moderngl", "glcontext", "numpy"):
        try:
            m = __import__(mod)
            out[mod] = getattr(m, "__version__", "?")
        except Exception:
            out[mod] = None
    return out


def diagnose_failure(error: Exception) -> dict:
    """What is missing, and what to do, when no OpenGL 4.3 context could be made."""
    missing: list[str] = []
    fixes: list[str] = []
    system = platform.system()
    if system == "Darwin":
        missing.append("OpenGL 4.3 (macOS provides at most 4.1, and no EGL)")
        fixes.append(FIX_MACOS)
    else:
        egl = ctypes.util.find_library("EGL")
        if egl is None:
            missing.append("libEGL (the EGL loader, libEGL.so.1)")
        text = str(error)
        if egl is not None and ("too old" in text or "below" in text):
            missing.append("an OpenGL 4.3 core driver (the driver found offers less)")
        if egl is not None and "0 devices" in text:
            missing.append("an EGL driver: libEGL loads but finds no device (glvnd's vendor files in "
                           "/usr/share/glvnd/egl_vendor.d, e.g. 50_mesa.json or 10_nvidia.json, are missing, "
                           "or __EGL_VENDOR_LIBRARY_FILENAMES points elsewhere)")
        if not missing:
            missing.append("a working EGL + OpenGL 4.3 driver (EGL loads, but no context could be created)")
        fixes += [FIX_DEBIAN, FIX_NVIDIA]
        if system == "Windows":
            fixes.insert(0, "Windows: mane's headless path uses EGL; run it under WSL2 with Mesa or a GPU driver")
    return {"error": str(error), "missing": missing, "fix": fixes}


# --------------------------------------------------------------------------- output

def _fmt_bytes(n) -> str:
    if n is None:
        return "unknown"
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{n:.0f} B"
        n /= 1024
    return f"{n:.1f} TiB"  # pragma: no cover


def _fmt_limit(key: str, value) -> str:
    if value is None:
        return "unknown"
    if isinstance(value, (list, tuple)):
        return " x ".join(str(v) for v in value)
    if key.endswith("_size") and key not in ("max_texture_size", "max_3d_texture_size") and value >= 1024:
        return f"{value} ({_fmt_bytes(value)})"
    return str(value)


def _table(rows, indent: str = "  ") -> list[str]:
    if not rows:
        return []
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(rows[0]) - 1)]
    out = []
    for r in rows:
        cells = [f"{str(c):<{w}}" for c, w in zip(r[:-1], widths)]
        out.append((indent + "  ".join(cells + [str(r[-1])])).rstrip())
    return out


def format_report(report: dict) -> str:
    lines = []
    kind = "software (CPU rasteriser)" if report["software"] else "GPU"
    lines.append("mane doctor")
    lines += _table([
        ("renderer", report["renderer"]),
        ("vendor", report["vendor"]),
        ("OpenGL", report["version"]),
        ("GLSL", report["glsl_version"]),
        ("runs on", kind),
        ("libraries", ", ".join(f"{k} {v}" for k, v in report["libraries"].items()
                                if k not in ("platform",) and v)),
    ])
    mem = report["memory"]
    lines.append("")
    lines.append("memory")
    lines += _table([("total", _fmt_bytes(mem["total"])),
                     ("available", _fmt_bytes(mem["available"])),
                     ("reported by", mem["source"])])
    lines.append("")
    lines.append("limits")
    lines += _table([(k, _fmt_limit(k, v)) for k, v in report["limits"].items()])
    lines.append("")
    lines.append("extensions")
    lines += _table([(name, "yes" if have else "no") for name, have in report["extensions"].items()])
    lines.append("")
    lines.append("features")
    rows = [("feature", "available", "why / what to do")]
    for name, f in report["features"].items():
        why = f["reason"] if f["available"] else f["reason"] + (f" -> {f['hint']}" if f.get("hint") else "")
        rows.append((f.get("label", name), "yes" if f["available"] else "NO", why))
    lines += _table(rows)
    if "selftest" in report:
        st = report["selftest"]
        lines.append("")
        lines.append(f"self-test: {'ok' if st['ok'] else 'FAILED'} ({st['detail']})")
    return "\n".join(lines)


def format_failure(diag: dict) -> str:
    lines = ["mane doctor: no usable OpenGL 4.3 context", f"  error: {diag['error']}", "  missing:"]
    lines += [f"    - {m}" for m in diag["missing"]]
    lines.append("  how to get it:")
    lines += [f"    - {f}" for f in diag["fix"]]
    return "\n".join(lines)


# --------------------------------------------------------------------------- command

def build_report(ctx, selftest: bool = True) -> dict:
    from ..gpu.capabilities import Capabilities
    from ..gpu.microbench import selftest as run_selftest

    caps = Capabilities.query(ctx)
    report = caps.as_dict()
    report["libraries"] = _library_versions()
    if selftest:
        report["selftest"] = run_selftest(ctx)   # a tiny compute shader, checked
    return report


def run(args) -> int:
    from ..errors import GPUError
    from ..gpu import context

    try:
        ctx = context.get_context()
    except (GPUError, ImportError, OSError) as exc:
        diag = diagnose_failure(exc)
        if args.json:
            print(json.dumps({"ok": False, "renderer": None, "software": None, **diag,
                              "libraries": _library_versions()}, indent=2))
        else:
            print(format_failure(diag), file=sys.stderr)
        return 1
    report = build_report(ctx, selftest=not args.no_selftest)
    ok = report.get("selftest", {"ok": True})["ok"] and report["features"]["compute_simulation"]["available"]
    report = {"ok": bool(ok), **report}
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(format_report(report))
    return 0 if ok else 1
