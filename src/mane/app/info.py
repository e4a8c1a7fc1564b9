"""``mane info FILE [--head MESH] [--units/--up/--scale ...] [--json]``: what a hair or mesh file holds.

Hair files: strands, points, points per strand (min / mean / max), bounding box, strand and
segment lengths, attributes and the format's own details (``Groom.stats()`` plus the loader's
metadata); the unit and up axis read or guessed (``frame``: each with its source, declared,
convention, guessed or option) and the checks: units plausible for hair, and with ``--head``
how the roots sit on the head (inside, far). Sizes are in metres, Y up, after the frame. Mesh files (``.obj .glb .gltf .stl .tfxmesh``, and ``.ply`` with faces but no
strands): vertices, faces, area, bounding box. ``--json`` prints exactly one JSON object.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..errors import FormatError, UnsupportedFormatError, not_a_file
from ..io import HAIR_FORMATS, MESH_FORMATS, load, load_mesh


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="a hair file (" + " ".join(sorted(HAIR_FORMATS)) + ") or a mesh ("
                        + " ".join(MESH_FORMATS) + ")")
    parser.add_argument("--head", metavar="MESH", help="a head mesh: report how the roots sit on it")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    from .options import add_frame_arguments

    add_frame_arguments(parser)


def is_mesh_file(path: Path) -> bool:
    """Mesh suffixes are meshes; a ``.ply`` is a mesh when it has faces and no strands."""
    suffix = path.suffix.lower()
    if suffix == ".ply":
        from ..io.strand_ply import read_header

        header = read_header(path)
        return header.element("strand") is None and header.element("face") is not None
    return suffix in MESH_FORMATS and suffix not in HAIR_FORMATS


def describe(path, args=None) -> dict:
    """The ``--json`` object for ``path`` (``args``: the frame options and --head)."""
    from .options import fit_warnings, load_groom, load_head

    path = Path(path)
    if not path.is_file():
        raise not_a_file(path)
    if is_mesh_file(path):
        # a mesh on its own takes the head options when given, else the groom ones
        mesh = load_mesh(path, units=_opt(args, "head_units", "units"), up=_opt(args, "head_up", "up"),
                         scale=getattr(args, "head_scale", None) or getattr(args, "scale", None))
        out = {"file": str(path), "kind": "mesh"}
        out.update(mesh.stats())
        meta = dict(mesh.metadata)
        if "bones" in meta:
            meta["num_bones"] = len(meta.pop("bones"))
        out["format"] = meta.pop("format", path.suffix.lstrip(".").upper())
        meta.pop("source", None)
        out["frame"] = meta.pop("frame", None)
        out["format_details"] = meta
        return out
    if path.suffix.lower() not in HAIR_FORMATS:
        raise UnsupportedFormatError(
            f"{path}: not a hair or mesh file mane knows; hair: {', '.join(sorted(HAIR_FORMATS))}; "
            f"meshes: {', '.join(MESH_FORMATS)}")
    groom = load_groom(args, path) if args is not None else load(path)
    out = {"file": str(path), "kind": "hair"}
    out.update(groom.stats())
    meta = dict(groom.metadata)
    meta.pop("source", None)
    out["format"] = meta.pop("format", path.suffix.lstrip("."))
    out["frame"] = meta.pop("frame", None)
    head = None
    if args is not None and getattr(args, "head", None):
        from ..io.units import check_fit

        head = load_head(args, args.head, groom)
        out["head"] = {"file": str(args.head), "frame": head.metadata.get("frame"), **head.stats()}
    checks = {"warnings": fit_warnings(groom, head)}
    if head is not None:
        fit = check_fit(groom, head)
        fit.pop("warnings")
        checks["fit"] = fit
    out["checks"] = checks
    out["format_details"] = _trim(meta)
    return out


def _opt(args, first, second):
    a = getattr(args, first, "auto") if args is not None else "auto"
    return a if a != "auto" else (getattr(args, second, "auto") if args is not None else "auto")


def _trim(value, depth=0):
    """Metadata for display: long lists (USC empty-slot points, ...) summarised."""
    if isinstance(value, dict):
        return {k: _trim(v, depth + 1) for k, v in value.items()}
    if isinstance(value, list) and (len(value) > 16 or (len(value) > 4 and isinstance(value[0], dict))):
        return f"[{len(value)} items]"
    if isinstance(value, list):
        return [_trim(v, depth + 1) for v in value]
    return value


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt(x) for x in v) + ")"
    if isinstance(v, dict):
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    return str(v)


def table(info: dict) -> str:
    rows: list[tuple[str, str]] = [("file", info["file"]), ("format", str(info["format"]))]
    if info["kind"] == "hair":
        pps = info["points_per_strand"]
        rows += [
            ("strands", f"{info['num_strands']:,}"),
            ("points", f"{info['num_points']:,}"),
            ("points per strand", f"min {pps['min']}  mean {pps['mean']:.2f}  max {pps['max']}"),
            ("strand length", _mmm(info["strand_length"])),
            ("segment length", _mmm(info["segment_length"])),
            ("zero-length segments", f"{info['zero_length_segments']:,}"),
        ]
    else:
        rows += [("vertices", f"{info['num_vertices']:,}"), ("faces", f"{info['num_faces']:,}"),
                 ("area", f"{info['area']:.6g}")]
    rows += [("bbox min", _fmt(info["bbox"]["min"])), ("bbox max", _fmt(info["bbox"]["max"])),
             ("attributes", ", ".join(info["attributes"]) or "-")]
    from ..io.units import frame_summary

    frame = info.get("frame")
    rows.append(("units, up", frame_summary(frame)))
    if frame and frame.get("guessed"):
        rows.append(("guessed", ", ".join(frame["guessed"]) + (f" ({'; '.join(frame['notes'])})"
                                                              if frame.get("notes") else "")))
    if "head" in info:
        rows.append(("head", info["head"]["file"]))
        rows.append(("head units, up", frame_summary(info["head"]["frame"])))
    checks = info.get("checks", {})
    if "fit" in checks:
        f = checks["fit"]
        rows.append(("roots on head", f"inside {100 * f['inside_fraction']:.1f}%  far {100 * f['far_fraction']:.1f}%"
                                      f"  median distance {100 * f['median_distance_m']:.2f} cm"))
    for w in checks.get("warnings", []):
        rows.append(("check", w))
    for key, value in info.get("format_details", {}).items():
        if isinstance(value, dict):
            for k, v in value.items():
                rows.append((f"{key}.{k}", _fmt(v)))
        else:
            rows.append((key, _fmt(value)))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v if v.strip() else '-'}" for k, v in rows)


def _mmm(d: dict) -> str:
    return f"min {d['min']:.6g}  mean {d['mean']:.6g}  max {d['max']:.6g}"


def run(args) -> int:
    info = describe(args.file, args)
    if args.json:
        print(json.dumps(info))
    else:
        print(table(info))
    return 0
