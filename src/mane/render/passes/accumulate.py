"""A still scene's frames averaged (``RenderSettings.accumulate``): more samples a pixel for a
picture that does not move.

While the camera, the lights, the hair, the head and the settings stay as they were, the k-th
frame after the first (k = 1, 2, ...) is drawn with the camera's image moved by a sub-pixel
offset, its strands at their true width (``jittered_view``), and folded into a running mean,
which the resolve shows in place of the frame. The offset: on the compute rasteriser, whose
samples lie on a regular grid, the k-th Halton (2, 3) point within one sample's cell
(``still_jitter``); on the raster units, whose 4x pattern is a rotated grid, an offset anywhere
in the pixel with each sample resolved from the pixel it fell in (sample_resolve.py). k frames
give k times a frame's samples a pixel, spread evenly over the pixel (a box filter, the path
tracer's): at msaa 4, 16 frames are 64 samples. After ``accumulate`` frames the mean is kept, and shown,
until something changes. The first frame of a still scene, and every frame of a moving one (a
simulation writes the hair every frame), is drawn at the pixel centres as it would be without
accumulation, and this pass does not run.

    r = Renderer(RenderSettings(accumulate=16))
    r.render(cam)               # a frame as ever; the next ones with cam add to the mean
    img = r.render_still(cam)   # as many frames as the mean still needs, then the image
"""
from __future__ import annotations

import math

from ...gpu.buffers import check_texture
from ...gpu.glsl import ProgramMemo, compute_shader
from ...gpu.uniforms import write_uniform
from ..bindings import IMG_ACCUM, TEX_HDR
from .base import Frame, Pass, View, shader_path


def halton(index: int, base: int) -> float:
    """The radical inverse of ``index`` in ``base``: the Halton sequence's point, in [0, 1)."""
    f, x, i = 1.0, 0.0, int(index)
    while i > 0:
        f /= base
        x += f * (i % base)
        i //= base
    return x


def still_jitter(k: int, grid: int) -> tuple[float, float]:
    """The k-th still frame's image offset (k >= 1), in pixels of the rendered target: the k-th
    Halton (2, 3) point within a sample's cell, which is 1 / ``grid`` of a pixel a side and
    centred on the sample (the samples of a pixel lie on a grid x grid lattice)."""
    return ((halton(k, 2) - 0.5) / grid, (halton(k, 3) - 0.5) / grid)


def jittered_view(view: View, dx: float, dy: float, size) -> View:
    """``view`` with its image moved by (dx, dy) pixels of a (w, h) target (clip x and y gain
    2 dx / w and 2 dy / h times clip w, so that every projection moves by the same pixels), its
    strands drawn at their true width: a frame alone widens a strand narrower than a sample
    (``min_pixel_width``) to one, with its coverage as opacity, lest it fall between samples,
    which blurs it over a sample; moved frames hit it as often as its width covers of the pixel,
    so that their mean converges to the exact coverage."""
    vp = view.view_proj.copy()
    vp[0] += (2.0 * dx / size[0]) * vp[3]
    vp[1] += (2.0 * dy / size[1]) * vp[3]
    return View(vp, view.eye, view.forward, view.ortho, view.pixel_size, 0.0)


class AccumulatePass(Pass):
    """Folds the k-th still frame's HDR colour into the mean (accumulate.comp)."""

    name = "accumulate"
    reads = ("hdr",)
    writes = ("still_mean",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self.texture = None   # the mean: RGBA32F at the rendered size, premultiplied like the HDR target

    def enabled(self, frame: Frame) -> bool:
        return 1 <= frame.still <= int(self.renderer.settings.accumulate)

    def run(self, frame: Frame) -> None:
        ctx = self.ctx
        hdr = self.renderer.resolved_hdr()   # blits the multisampled target when there is one
        w, h = hdr.size
        if self.texture is None or self.texture.size != (w, h):
            self.release()
            check_texture(ctx, (w, h), 4, 4, f"the {w}x{h} mean of a still scene's frames",
                          reduce="Use a smaller --size, no supersampling or accumulate 1")
            self.texture = ctx.texture((w, h), 4, dtype="f4")
        cs = self._programs.get("accumulate", (), lambda: compute_shader(ctx, shader_path("accumulate.comp")))
        hdr.use(TEX_HDR)
        write_uniform(cs["u_frame"], TEX_HDR)
        write_uniform(cs["u_weight"], 1.0 / frame.still)
        self.texture.bind_to_image(IMG_ACCUM, read=True, write=True)
        cs.run(math.ceil(w / 8), math.ceil(h / 8))
        ctx.memory_barrier()

    def release(self) -> None:
        if self.texture is not None:
            self.texture.release()
            self.texture = None
