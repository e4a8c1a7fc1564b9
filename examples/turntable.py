"""Render a turntable of a groom: the camera circles the head once, into an MP4.

    python examples/turntable.py [--frames 72] [--size 640x360] [--out out/examples/turntable.mp4]
"""
import argparse
from pathlib import Path

import imageio.v2 as imageio

from load_and_render import load_scene
from mane.render import Renderer, RenderSettings, default_lights


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=72)
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--out", default="out/examples/turntable.mp4")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    groom, head, what = load_scene()
    renderer = Renderer(RenderSettings(size=(w, h), strands_per_guide=8, shadows="deep_opacity", msaa=4))
    renderer.set_strands(groom)
    renderer.set_head(head)
    camera, lights = renderer.default_camera(0.0, 10.0), default_lights()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with imageio.get_writer(out, fps=24, codec="libx264", macro_block_size=1, ffmpeg_log_level="error") as video:
        for i in range(args.frames):
            video.append_data(renderer.render_image(camera.orbited(360.0 * i / args.frames), lights))
    print(f"{what}: wrote {out} ({args.frames} frames, {w}x{h})")
    renderer.release()


if __name__ == "__main__":
    main()
