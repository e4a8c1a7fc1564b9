"""The second scene: Sintel's TressFX groom on her bust (../shared/data; CC BY 3.0, Blender
Foundation), at full density (64 rendered strands per guide), from the front, 3/4 and back.

    python examples/sintel.py [--size 960x540] [--out out/examples/sintel.png]

Skips (exit 0, with a message) when the data is absent: it is not part of mane.
"""
import argparse
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def main():
    from mane.errors import GroomError
    from mane.render import Renderer
    from mane.render.lights import default_lights
    from mane.presets import SINTEL_CREDIT, sintel_render_settings, sintel_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="960x540", help="WxH of each view")
    ap.add_argument("--out", default="out/examples/sintel.png", help="a PNG with the three views side by side")
    ap.add_argument("--data", default=str(DATA), help="the folder with tressfx/ and heads/")
    ap.add_argument("--strands-per-guide", type=int, default=None)
    args = ap.parse_args()
    try:
        groom, head = sintel_scene(args.data)
    except GroomError as exc:
        print(f"skipped: {exc}")
        return
    w, h = (int(v) for v in args.size.split("x"))
    kw = {} if args.strands_per_guide is None else {"strands_per_guide": args.strands_per_guide}
    r = Renderer(sintel_render_settings(size=(w, h), **kw), profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        views = [r.render_image(r.default_camera(az, 8.0), default_lights()) for az in (0.0, 35.0, 180.0)]
    finally:
        r.release()
    from PIL import Image

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.concatenate(views, axis=1)).save(out)
    print(f"{SINTEL_CREDIT}: {groom.num_strands} guides x {r.settings.strands_per_guide} strands; wrote {out}")


if __name__ == "__main__":
    main()
