"""Simulate a groom on the GPU while the head nods and a sphere passes through the hair; print
what the solver guarantees (lengths, roots, no particle inside a collider) every half second.

    python examples/simulate.py [--seconds 2] [--fps 30]
"""
import argparse
import math

import numpy as np

from load_and_render import load_scene
from mane.sim import MeshCollider, SimSettings, Simulator, Sphere, head_motion


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--fps", type=float, default=30.0)
    args = ap.parse_args()
    groom, head, what = load_scene()
    lo, hi = groom.bbox()
    centre, size = (lo + hi) / 2, float(np.max(hi - lo))
    sphere = Sphere(center=centre + [size, 0, 0], radius=0.15 * size)
    sim = Simulator(groom, colliders=[MeshCollider(head), sphere],
                    settings=SimSettings(local_shape_stiffness=0.05, damping=1.0))
    print(f"{what}: {sim.state.num_strands} strands x {sim.state.points_per_strand} particles")
    frames = int(round(args.seconds * args.fps))
    for i in range(1, frames + 1):
        t = i / args.fps
        sim.set_head_transform(head_motion.nod(t))
        sphere.move_to(centre + size * np.array([0.6 * math.cos(2 * t), -0.1, 0.6 * math.sin(2 * t)]))
        sim.advance(1.0 / args.fps)
        if i % max(1, int(args.fps / 2)) == 0 or i == frames:
            print(f"t={t:5.2f} s  steps {sim.state.steps:4d}  length error {sim.max_length_error():.1e}  "
                  f"root error {sim.max_root_error() * 1e3:.3f} mm  "
                  f"inside the sphere {sim.max_penetration() * 1e3:.3f} mm")
    sim.release()


if __name__ == "__main__":
    main()
