"""``mane view [GROOM] [--head MESH]``: the interactive viewer (see mane.viewer)."""
from __future__ import annotations

HELP = "open the interactive viewer: simulate, light and render a groom live (needs a display)"


def _size(text: str) -> tuple[int, int]:
    from ..errors import UsageError

    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UsageError(f"--size must be WIDTHxHEIGHT, got {text!r}") from None
    return w, h


def add_arguments(parser) -> None:
    parser.add_argument("groom", nargs="?", help="hair file (any format mane reads; default: the procedural groom)")
    parser.add_argument("--head", help="head or body mesh (.obj, .ply, .glb, .gltf, .stl, .tfxmesh)")
    parser.add_argument("--size", default="960x540", help="window size WIDTHxHEIGHT (default 960x540)")
    parser.add_argument("--quality", choices=("auto", "software", "gpu"), default="auto",
                        help="workload preset (auto: by the OpenGL renderer)")
    parser.add_argument("--motion", choices=("none", "nod", "shake", "turn"), default="none",
                        help="head motion preset to start with")
    parser.add_argument("--demo", action="store_true", help="the demo's sweeping sphere, nodding head and gusts")
    parser.add_argument("--out", default="out/viewer", help="folder for screenshots and recordings")
    parser.add_argument("--frames", type=int, default=None, help="quit after this many frames (scripts, tests)")
    parser.add_argument("--screenshot", default=None, help="save a screenshot to this PNG when quitting")
    from .options import add_frame_arguments
    from .settings_args import add_settings_arguments

    add_frame_arguments(parser)
    add_settings_arguments(parser, ("render", "sim"))


def run(args) -> int:
    from ..viewer import Viewer
    from .options import fit_warnings, load_groom, load_head
    from .settings_args import check_settings

    check_settings(args)     # --config and --set: a bad name or value before the window opens
    groom = load_groom(args, args.groom) if args.groom else None
    head = load_head(args, args.head, groom) if args.head else None
    if groom is not None:
        for w in fit_warnings(groom, head):
            print(f"mane view: warning: {w}")
    viewer = Viewer(groom, head, size=_size(args.size), quality=args.quality, demo=args.demo,
                    motion=args.motion if not args.demo or args.motion != "none" else None, out_dir=args.out)
    try:
        apply_viewer_settings(viewer, args)
        print(f"mane view: {viewer.status}")
        n = viewer.run(max_frames=args.frames)
        if args.screenshot:
            viewer.screenshot(args.screenshot)
            viewer.frame()
            print(f"mane view: screenshot {viewer.last_screenshot}")
        print(f"mane view: {n} frames, {viewer.fps:.1f} frames per second; {viewer.quality_report()}")
        if viewer.error:
            print(f"mane view: last error: {viewer.error}")
    finally:
        viewer.close()
    return 0


def apply_viewer_settings(viewer, args) -> None:
    """The command line's ``--config``/``--set`` over the viewer's starting settings."""
    from .settings_args import apply_settings

    viewer.render_settings = apply_settings(viewer.render_settings, args, "render")
    if viewer.sim is not None:
        viewer.sim.settings = apply_settings(viewer.sim.settings, args, "sim")
