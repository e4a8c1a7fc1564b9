"""One reference pass in a child process (``passes.WORKER`` runs it):

    python -m mane.reference.worker JOB.json OUT.npy

JOB.json is ``render.scene_job``'s plain description of the scene plus "spp" and "seed"; the
pass is path traced by Mitsuba (``render.scene_from_job``) and written to OUT.npy as float32
(H, W, 3) linear radiance. A crash of Mitsuba here ends this process only (passes.py).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from .render import mitsuba, scene_from_job


def main(argv) -> int:
    if len(argv) != 2:
        print("usage: python -m mane.reference.worker JOB.json OUT.npy", file=sys.stderr)
        return 2
    job_path, out_path = argv
    job = json.loads(Path(job_path).read_text())
    mi = mitsuba(job.get("variant"))
    scene = mi.load_dict(scene_from_job(mi, job))
    image = np.array(mi.render(scene, seed=int(job["seed"]), spp=int(job["spp"])), np.float32)[..., :3]
    with open(out_path, "wb") as f:
        np.save(f, image, allow_pickle=False)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
