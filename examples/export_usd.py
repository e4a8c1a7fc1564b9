"""Simulate a groom and export the animation as USD curves (one time sample per frame), then
read it back to check it.

    python examples/export_usd.py [--frames 48] [--out out/examples/hair_anim.usda]
"""
import argparse
from pathlib import Path

import mane
from load_and_render import load_scene
from mane.io import usd_curves
from mane.sim import MeshCollider, SimSettings, Simulator, WindSettings, head_motion


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=48)
    ap.add_argument("--fps", type=float, default=24.0)
    ap.add_argument("--out", default="out/examples/hair_anim.usda")
    args = ap.parse_args()
    groom, head, what = load_scene()
    sim = Simulator(groom, colliders=[MeshCollider(head)],
                    settings=SimSettings(drag=1.0, wind=WindSettings(velocity=(1.0, 0.0, 0.5), gust=0.8)))
    frames = []
    for i in range(args.frames):
        sim.set_head_transform(head_motion.shake(i / args.fps))
        sim.advance(1.0 / args.fps)
        frames.append(sim.positions())
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    usd_curves.write(sim.groom, out, frames=frames, fps=args.fps)
    back = mane.load(out)
    print(f"{what}: wrote {out}: {back.num_strands} curves, "
          f"{back.metadata['usd']['num_time_samples']} time samples")
    sim.release()


if __name__ == "__main__":
    main()
