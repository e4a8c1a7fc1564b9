"""``mane simulate GROOM [--head MESH] [--seconds S] [--fps F] [--out anim.usd|anim.npz] [--stats stats.json]``

Runs the GPU strand solver on a groom (a hair file, or ``default`` for mane's default head
and groom when ``mane.grooming`` provides them) while the head moves (``--motion``), and
writes the animation (USD curves with time samples, or an ``.npz`` with a ``frames`` array
(F, P, 3)) and a JSON of statistics: mean GPU milliseconds per pass, steps, the renderer,
and invariants measured over the whole run (largest relative segment length error, root
error and penetration, NaN recoveries).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import ManeError, UsageError

HELP = "simulate a groom on the GPU while the head moves; write the animation and statistics"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("groom", help="a hair file, or 'default' for mane's default head and groom")
    parser.add_argument("--head", metavar="MESH", help="a head/body mesh to collide with (through its SDF)")
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated time, s (default 2)")
    parser.add_argument("--fps", type=float, default=30.0, help="frames per second written (default 30)")
    parser.add_argument("--out", metavar="FILE", help="animation: .usd/.usda/.usdc (curves) or .npz (frames)")
    parser.add_argument("--stats", metavar="JSON", help="write timings and invariants here")
    parser.add_argument("--motion", default="nod", choices=["none", "nod", "shake", "turn"],
                        help="head motion preset (default nod)")
    parser.add_argument("--points", type=int, default=16, help="points per simulated strand, 2..64 (default 16)")
    parser.add_argument("--max-strands", type=int, default=0,
                        help="simulate at most this many strands (evenly picked guides; 0 = all)")
    parser.add_argument("--method", default="dftl", choices=["dftl", "pbd"], help="length constraint")
    parser.add_argument("--dt", type=float, default=1 / 120, help="fixed step, s (default 1/120)")
    parser.add_argument("--friction", type=float, default=0.0, help="hair-hair friction in [0, 1]")
    parser.add_argument("--local-shape", type=float, default=0.05, help="local shape stiffness in [0, 1]")
    parser.add_argument("--wind", default="0,0,0", help="mean wind velocity 'x,y,z' in m/s")
    parser.add_argument("--gust", type=float, default=0.5, help="gust strength (fraction of the wind speed)")
    parser.add_argument("--drag", type=float, default=0.5, help="air drag rate, 1/s")
    parser.add_argument("--max-frames", type=int, default=None,
                        help="frame budget: refuse --seconds x --fps beyond it (default 10000); steps "
                             "are bounded by 100 per frame of it")
    from .options import add_frame_arguments, add_quiet_argument
    from .settings_args import add_settings_arguments

    add_frame_arguments(parser)
    add_quiet_argument(parser)
    add_settings_arguments(parser, ("sim",))


def _vector(text: str) -> tuple[float, float, float]:
    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise UsageError(f"expected three numbers 'x,y,z', got {text!r}")
    return v


def _load_scene(args):
    """(groom, head mesh or None)."""
    from .options import load_groom, load_head

    if args.groom != "default":
        groom = load_groom(args, args.groom)
        return groom, (load_head(args, args.head, groom) if args.head else None)
    head = load_head(args, args.head) if args.head else None
    from ..grooming import default_head, simulation_groom

    return simulation_groom(), (head if head is not None else default_head())


def _check_arguments(args) -> int:
    """Every number in its documented range, the outputs writable and the work within its
    budget, before anything is loaded; returns the frames to make."""
    from ..io.atomic import check_output_path
    from ..sim import SimSettings, WindSettings
    from .checks import MAX_FRAMES, MAX_STEPS_PER_FRAME, frame_budget, number, setting_number
    from .settings_args import check_settings

    number("--seconds", args.seconds, lo=0, lo_open=True)
    number("--fps", args.fps, lo=0, hi=1000, lo_open=True)
    number("--points", args.points, lo=2, hi=64, integer=True)
    number("--max-strands", args.max_strands, lo=0, integer=True)
    for flag, cls, name in (("--dt", SimSettings, "dt"), ("--friction", SimSettings, "friction"),
                            ("--local-shape", SimSettings, "local_shape_stiffness"),
                            ("--drag", SimSettings, "drag"), ("--gust", WindSettings, "gust")):
        setting_number(flag, cls, name, getattr(args, flag[2:].replace("-", "_")))
    check_settings(args)     # --config and --set: a bad name or value before any work
    if args.out and Path(args.out).suffix.lower() not in (".usd", ".usda", ".usdc", ".npz"):
        raise UsageError(f"--out must end in .usd, .usda, .usdc or .npz, got {args.out}")
    max_frames = args.max_frames if args.max_frames is not None else MAX_FRAMES
    n_frames = max(1, int(round(args.seconds * args.fps)))
    frame_budget(n_frames, max_frames, f"--seconds {args.seconds:g} x --fps {args.fps:g}")
    from .settings_args import apply_settings

    dt = apply_settings(SimSettings(dt=args.dt), args, "sim").dt    # --set dt=... too
    steps = math.ceil(args.seconds / dt)
    if steps > max_frames * MAX_STEPS_PER_FRAME:
        raise UsageError(f"--seconds {args.seconds:g} / --dt {dt:g} is {steps:,} steps, more than the "
                         f"budget of {max_frames * MAX_STEPS_PER_FRAME:,} ({MAX_STEPS_PER_FRAME} per frame of "
                         f"--max-frames); simulate less time or raise --max-frames")
    if args.out:
        check_output_path(args.out, "--out")
    if args.stats:
        check_output_path(args.stats, "--stats")
    return n_frames


def _pick_strands(groom, max_strands: int):
    if max_strands and groom.num_strands > max_strands:
        idx = np.linspace(0, groom.num_strands - 1, max_strands).round().astype(np.int64)
        return groom.subset(np.unique(idx))
    return groom


def run(args) -> int:
    from ..gpu import get_context, renderer_name
    from ..sim import SimSettings, Simulator, WindSettings, head_motion
    from ..sim.colliders import head_collider

    n_frames = _check_arguments(args)
    groom, head = _load_scene(args)
    if args.groom != "default":
        from .options import fit_warnings

        for w in fit_warnings(groom, head):   # roots inside the collider start penetrating it
            print(f"mane simulate: warning: {w}", file=sys.stderr)
    groom = _pick_strands(groom, args.max_strands)
    wind = WindSettings(velocity=_vector(args.wind), gust=args.gust)
    settings = SimSettings(dt=args.dt, length_method=args.method, friction=args.friction,
                           local_shape_stiffness=args.local_shape, drag=args.drag, wind=wind)
    from .settings_args import apply_settings

    settings = apply_settings(settings, args, "sim")
    colliders = []
    if head is not None:
        colliders.append(head_collider(head))
    ctx = get_context()
    sim = Simulator(groom, colliders, settings, ctx, points_per_strand=args.points, profile=bool(args.stats))
    # the head turns about its neck: below the roots' bounding box, at its centre
    if head is not None:
        lo, hi = head.bbox()
    else:
        lo, hi = sim.groom.roots.min(axis=0), sim.groom.roots.max(axis=0)
    pivot = ((lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2)
    motion = head_motion.preset(args.motion, pivot=pivot)

    worst = {"max_length_error": 0.0, "max_root_error": 0.0, "max_penetration": 0.0}
    start = time.perf_counter()
    from ..progress import progress

    with _FrameStream(args.out, n_frames, sim.groom, args.fps) as stream:
        for f in progress(range(n_frames), desc="simulate", unit="frame", quiet=args.quiet):
            sim.set_head_transform(motion((f + 1) / args.fps))
            sim.advance(1.0 / args.fps)
            p = sim.positions()
            worst["max_length_error"] = max(worst["max_length_error"], sim.max_length_error(positions=p))
            worst["max_root_error"] = max(worst["max_root_error"], sim.max_root_error(positions=p))
            worst["max_penetration"] = max(worst["max_penetration"], _penetration(sim, p))
            stream.append(p)
        wall = time.perf_counter() - start
        if not all(math.isfinite(v) for v in worst.values()) or sim.state.steps == 0:
            raise ManeError(f"the simulation went wrong: {worst}; nothing written")
        stream.finish()
    stats = {
        "renderer": renderer_name(ctx),
        "strands": sim.groom.num_strands,
        "points_per_strand": sim.state.points_per_strand,
        "frames": n_frames,
        "steps": sim.state.steps,
        "dt": settings.dt,
        "seconds": args.seconds,
        "wall_seconds": wall,
        "passes": sim.pass_times() if args.stats else {},
        **worst,
        "nan_recoveries": sim.nan_recoveries,
        "warnings": sim.warnings,
        "settings": {"length_method": settings.length_method, "friction": settings.friction,
                     "local_shape_stiffness": settings.local_shape_stiffness, "motion": args.motion},
    }
    if args.stats:
        from ..io.atomic import atomic_write_path

        with atomic_write_path(args.stats) as tmp:
            Path(tmp).write_text(json.dumps(stats, indent=2))
    print(f"simulated {sim.groom.num_strands} strands x {sim.state.points_per_strand} points, "
          f"{n_frames} frames, {sim.state.steps} steps in {wall:.2f} s on {stats['renderer']}; "
          f"max length error {worst['max_length_error']:.2e}, root error {worst['max_root_error']:.2e} m, "
          f"penetration {worst['max_penetration']:.2e} m, NaN recoveries {sim.nan_recoveries}")
    for w in sim.warnings:
        print(f"mane simulate: {w}")
    return 0


def _penetration(sim, p) -> float:
    """Deepest free particle inside a collider (primitives exactly, meshes through their SDF)."""
    from ..sim import MeshCollider

    deepest = sim.max_penetration(positions=p)
    free = sim.state.inv_mass > 0
    for c in sim.colliders:
        sdf = getattr(c, "_sdf", None)
        if isinstance(c, MeshCollider) and sdf is not None and hasattr(sdf, "sample"):
            world = c.world_transform(sim.state.head)
            inv = np.linalg.inv(world)
            local = p[free].astype(np.float64) @ inv[:3, :3].T + inv[:3, 3]
            d = np.asarray(sdf.sample(local), dtype=np.float64)
            deepest = max(deepest, float(np.max(-d, initial=0.0)))
    return deepest


class _FrameStream:
    """Frames written to disk as they come (a float32 .npy memory map beside the output, so a
    long run holds one frame in memory), turned into the output at ``finish``. Interrupted
    (Ctrl-C, SIGTERM), the frames made so far are written to NAME.partial.npz/.usd; the
    memory map is removed whatever happens."""

    def __init__(self, out, n_frames: int, groom, fps: float):
        self.out = Path(out) if out else None
        self.groom, self.fps, self.count = groom, fps, 0
        self.frames = None
        self._tmp = None
        if self.out is not None:
            import os
            import re

            stem = re.sub(r"[^A-Za-z0-9_+-]", "_", self.out.stem)[:40]
            folder = self.out.parent if str(self.out.parent) else Path(".")
            self._tmp = folder / f".{stem}.mane-{os.getpid()}-frames.tmp.npy"
            try:
                self.frames = np.lib.format.open_memmap(self._tmp, mode="w+", dtype=np.float32,
                                                        shape=(n_frames, groom.num_points, 3))
            except OSError as exc:
                from ..io.atomic import os_error

                raise os_error(self.out, exc) from None

    def __enter__(self):
        return self

    def append(self, positions) -> None:
        if self.frames is not None:
            self.frames[self.count] = positions
        self.count += 1

    def finish(self) -> None:
        if self.frames is not None:
            self.frames.flush()
            _write(self.groom, self.out, self.frames[:self.count], self.fps)

    def __exit__(self, kind, exc, tb) -> None:
        try:
            if kind is not None and issubclass(kind, KeyboardInterrupt) and self.frames is not None and self.count:
                from ..io.atomic import partial_path

                part = partial_path(self.out)
                _write(self.groom, part, self.frames[:self.count], self.fps)
                print(f"mane simulate: interrupted; the {self.count} frames made so far are in {part}")
        finally:
            self.frames = None
            if self._tmp is not None:
                import contextlib

                with contextlib.suppress(OSError):
                    self._tmp.unlink()


def _write(groom, path: Path, frames, fps: float) -> None:
    if path.suffix.lower() == ".npz":
        from ..io.atomic import atomic_write_path

        with atomic_write_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, frames=np.asarray(frames, dtype=np.float32), counts=groom.counts,
                                    fps=np.float32(fps), rest=groom.points)
        return
    from ..io import usd_curves

    usd_curves.write(groom, path, frames=frames, fps=fps)
