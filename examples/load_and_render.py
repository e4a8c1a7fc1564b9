"""Load a real groom (Sintel's hair on her bust, from ../shared/data when it is there; otherwise
the procedural default) and render it to a PNG.

    python examples/load_and_render.py [--size 640x480] [--out out/examples/sintel.png]
"""
import argparse
from pathlib import Path

import mane

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def load_scene():
    """(groom, head) in metres: Sintel (centimetres in the files: mane.load turns them into
    metres, and the bust, stored in the groom's frame, gets the same transform) or the
    procedural default."""
    hair, bust = DATA / "tressfx" / "sintel_hair.tfx", DATA / "heads" / "sintel.obj"
    if hair.is_file() and bust.is_file():
        groom = mane.load(hair)
        head = mane.load_mesh(bust, like=groom)
        return groom, head, "Sintel (c) Blender Foundation, CC BY 3.0"
    from mane.grooming.scene import default_scene

    groom, head = default_scene()
    return groom, head, "the procedural default groom"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--out", default="out/examples/groom.png")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    groom, head, what = load_scene()
    print(f"{what}: {groom.num_strands} strands, {groom.num_points} points")
    image = mane.render_image(groom, head, size=(w, h), strands_per_guide=8, shadows="deep_opacity",
                              as_pil=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    image.save(out)
    print(f"wrote {out} ({image.size[0]}x{image.size[1]})")


if __name__ == "__main__":
    main()
