"""``mane convert IN OUT [--units U] [--up AXIS] [--scale S] [--points N] [--quiet]``: read a
hair or mesh file, write another format.

The input is read in metres, Y up (``--units``/``--up``/``--scale`` say what the file holds
when it does not say itself; by default a unit and axis are read, taken from the format's
convention or guessed, with a warning: ``mane info`` shows which) and written in the output
format's convention, declaring metres where the format can (USD metersPerUnit/upAxis, .npz
metadata, PLY comments, cyHair info text, TressFX reserved words). ``--points N`` resamples
every strand to N points (equal arc length); ``.tfx`` output takes 4, 8, 16, 32 or 64 (by
default the one nearest the strands' median). Meshes (``.obj .ply .glb .gltf .stl .tfxmesh``
in; ``.obj .ply .glb .stl`` out, through trimesh) convert the same way. A PLY input is a mesh
when it has faces and no strands.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..errors import UsageError
from ..io import HAIR_FORMATS, MESH_FORMATS, save
from .options import add_frame_arguments, add_quiet_argument, load_groom

MESH_OUT = (".obj", ".ply", ".glb", ".stl")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", help="hair file (" + " ".join(sorted(HAIR_FORMATS)) + ") or mesh ("
                        + " ".join(MESH_FORMATS) + ")")
    parser.add_argument("output", help="file to write; its suffix picks the format (meshes: "
                        + " ".join(MESH_OUT) + ")")
    parser.add_argument("--points", type=int, default=None,
                        help="resample every strand to N points (.tfx: 4, 8, 16, 32 or 64)")
    add_frame_arguments(parser, head=False)
    add_quiet_argument(parser)


def _convert_mesh(args, src: Path, dst: Path) -> int:
    from ..io import load_mesh

    if dst.suffix.lower() not in MESH_OUT:
        raise UsageError(f"{src} is a mesh: write it as one of {', '.join(MESH_OUT)}, not {dst.suffix or dst.name}")
    if args.points is not None:
        raise UsageError("--points resamples strands; a mesh has none")
    mesh = load_mesh(src, units=args.units, up=args.up, scale=args.scale)
    import numpy as np
    import trimesh

    from ..io.atomic import atomic_write_path

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, vertex_normals=mesh.normals, process=False)
    if mesh.colors is not None:
        tm.visual.vertex_colors = (np.clip(mesh.colors, 0, 1) * 255).astype(np.uint8)
    with atomic_write_path(dst) as tmp:
        tm.export(str(tmp), file_type=dst.suffix.lower().lstrip("."))
    frame = mesh.metadata.get("frame", {})
    print(f"{src} (mesh) -> {dst}: {len(mesh.vertices):,} vertices, {len(mesh.faces):,} faces, "
          f"metres, Y up (from {frame.get('file_units')}, {frame.get('file_up')}-up)")
    return 0


def run(args) -> int:
    from .info import is_mesh_file

    from ..io.atomic import check_output_path

    src, dst = Path(args.input), Path(args.output)
    check_output_path(dst, "output")
    if src.exists() and is_mesh_file(src):
        return _convert_mesh(args, src, dst)
    from ..progress import stage

    t0 = time.perf_counter()
    bar = stage("convert", 3, quiet=args.quiet)   # read, resample, write (shown after 2 s)
    try:
        bar.set_postfix_str("read", refresh=False)
        groom = load_groom(args, src)
        bar.update(1)
        options = {}
        if args.points is not None:
            if dst.suffix.lower() == ".tfx":
                options["points"] = args.points   # the writer checks 4..64 and resamples
            else:
                groom = groom.resampled(args.points)
        bar.update(1)
        bar.set_postfix_str("write", refresh=False)
        save(groom, dst, **options)
        bar.update(1)
    finally:
        bar.close()
    fmt = groom.metadata.get("format", src.suffix.lstrip("."))
    frame = groom.metadata.get("frame", {})
    extra = [f"from {frame.get('file_units')} ({frame.get('units_source')}), "
             f"{frame.get('file_up')}-up ({frame.get('up_source')}) to metres, Y up"]
    if args.points is not None:
        extra.append(f"{args.points} points per strand")
    print(f"{src} ({fmt}) -> {dst}: {groom.num_strands:,} strands, {groom.num_points:,} points "
          f"({'; '.join(extra)}) in {time.perf_counter() - t0:.1f} s")
    return 0
