"""Deep opacity maps (Yuksel and Keyser 2008) for the hair's self-shadowing, from light 0.

1. z0: the hair's nearest linear light depth (m) per texel (depth test on).
2. opacity: depth test off, additive blending; each hair fragment adds ``strand_opacity``
   (times its coverage) to its own layer and every layer behind it; the layers end at
   z0 + d_k, d_k = ``dom_layers`` fractions of the hair's depth extent (5%, 15%, the rest).
3. z0 is copied into the alpha channel, so that shading reads one RGBA texel:
   (O1, O2, O3, z0); T(z) = exp(-density * O(z)), O piecewise linear between the layer ends.

With the compute rasteriser (Renderer.compute_raster) the same three steps run as compute
dispatches over the expanded strands (dom_raster.comp, dom_pack.comp): atomic min of the depth
bits for z0, fixed-point atomic adds (1/65536) for the layers. There the map has its own LOD
(``strand_step``, coverage_lod.light_strand_step): where the light sees more than 2
``lod_depth`` strands over a texel (a 1M-strand groom's kept strands: D_light = 280 with the
1024 map), the layers' dispatch scan-converts every m-th expanded strand at m times the
opacity, m = floor(D_light / lod_depth): the same opacity per texel in expectation, m times
fewer samples visited; z0 still comes from every strand (``Z0_EVERY_STRAND``). On a 48k-strand
head at m = 4 (llvmpipe, 320 x 320) the image's luminance moved +0.9 % and 1.2 % per pixel (the
exponential of a noisier opacity is brighter on average: Jensen).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ...gpu.glsl import ProgramMemo, compute_shader, program
from ..bindings import B_DOM_LAYERS, B_DOM_Z0, IMG_DOM, TEX_DOM_Z0
from .base import (FAR, HERE, shader_path, PASS_DOM_DEPTH, PASS_DOM_OPACITY, RENDER_DIR, Frame, draw_hair, hair_program,
                   read_f32, set_uniform, set_uniforms, set_view)
from ..coverage_lod import light_strand_step, mean_width
from .light_depth import LightDepthPass
from .raster_segment import raster_defines, subgroup_defines


Z0_EVERY_STRAND = True
"""The map's LOD thins the opacity layers' dispatch only: z0, the nearest strand, from every
strand (the nearest of fewer lies deeper: +13 % of opacity in the first layer at m = 4)."""


class DeepOpacityPass(LightDepthPass):
    """The light-depth map holds z0, the nearest hair's light depth (hardware path)."""

    name = "deep_opacity"
    method = "deep_opacity"
    reads = ("strands",)
    writes = ("dom",)

    def __init__(self, renderer):
        super().__init__(renderer)
        ctx = self.ctx
        n = self.map_size()
        from ...gpu.buffers import check_texture

        check_texture(ctx, (n, n), 4, 4, f"the deep opacity map ({n}x{n} RGBA32F, with its depth maps)",
                      extra_bytes=n * n * 8, reduce="Use a smaller shadow_map_size")
        self.depth_target()
        self.opacity = ctx.texture((n, n), 4, dtype="f4")
        self.opacity.filter = (ctx.NEAREST, ctx.NEAREST)
        self.opacity_fbo = ctx.framebuffer([self.opacity])
        self._counters = None   # compute path: (z0 bits, 3 layer sums) per texel
        self._programs = ProgramMemo()
        self._layers = None     # (settings, light view, hair depth range, _layer_uniforms)
        self._step = None       # (what strand_step was made of, the stride)
        self.last_step = None   # the last compute frame's stride (None: none drawn by compute yet)

    def run(self, frame: Frame) -> None:
        if self.renderer.compute_raster:
            self.run_compute(frame)
            return
        ctx, r = self.ctx, self.renderer
        # 1. z0
        self.begin_depth(cull=True)
        draw_hair(r, hair_program(r, PASS_DOM_DEPTH, instance=self.instance), frame.light_view)
        # 2. opacity layers
        layer_ends, opacity = self._layer_uniforms(frame)
        prog = hair_program(r, PASS_DOM_OPACITY, instance=self.instance)
        self.texture.use(TEX_DOM_Z0)
        set_uniform(prog, "u_dom_depth", TEX_DOM_Z0)
        set_uniform(prog, "u_dom_layers_abs", layer_ends)
        set_uniform(prog, "u_strand_opacity", opacity)
        self.opacity_fbo.color_mask = (True, True, True, True)
        self.opacity_fbo.use()
        self.opacity_fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.ONE, ctx.ONE)
        ctx.blend_equation = ctx.FUNC_ADD
        draw_hair(r, prog, frame.light_view)
        ctx.disable(ctx.BLEND)
        # 3. z0 into alpha
        pack = program(ctx, vertex=shader_path("fullscreen.vert"), fragment=shader_path("dom_pack.frag"),
                       instance=self.instance)
        set_uniform(pack, "u_dom_depth", TEX_DOM_Z0)
        self.opacity_fbo.color_mask = (False, False, False, True)
        self.opacity_fbo.use()   # moderngl applies a framebuffer's colour mask when it is bound
        r.empty_vao(pack).render(ctx.TRIANGLES, vertices=3)
        self.opacity_fbo.color_mask = (True, True, True, True)
        self.opacity_fbo.use()
        ctx.enable(ctx.DEPTH_TEST)
        frame.targets["dom"] = self.opacity

    def run_compute(self, frame: Frame) -> None:
        ctx, r = self.ctx, self.renderer
        n = self.map_size()
        if self._counters is None:
            from ...gpu.buffers import check_allocation

            check_allocation(ctx, n * n * 16, f"the deep opacity counters ({n}x{n})",
                             reduce="Use a smaller shadow_map_size")
            z0 = ctx.buffer(np.full(n * n, 0xFFFFFFFF, np.uint32).tobytes())
            layers = ctx.buffer(reserve=n * n * 12)
            layers.write(bytes(n * n * 12))
            self._counters = (z0, layers)
        z0, layers = self._counters
        z0.bind_to_storage_buffer(B_DOM_Z0)
        layers.bind_to_storage_buffer(B_DOM_LAYERS)
        layer_ends, opacity = self._layer_uniforms(frame)
        # each dispatch's form by measurement (scan_form.py: the sites dom_z0 and dom, each
        # dispatch timed); the extra lights' maps (extra_shadows.py) take the main light's choices untimed
        main = r.get_pass("deep_opacity") is self
        if main:
            expand = r.get_pass("expand")
            expand.ensure()
            sizes = (expand.segments, 1 if r.instances is None else len(r.instances))
        step = self.last_step = self.strand_step(frame)
        for dom_pass, site in ((0, r.scan_forms.dom_z0), (1, r.scan_forms.dom)):
            form = site.begin(r.settings, sizes) if main else site.current()
            scan_light_depths(r, frame.light_view, n, dom_pass, layer_ends=layer_ends, strand_opacity=opacity,
                              balance=form, programs=self._programs, instance=self.instance,
                              strand_step=1 if dom_pass == 0 and self.z0_every_strand() else step)
            if main:
                site.end()
        pack = self._programs.get("pack", (), lambda: compute_shader(ctx, shader_path("dom_pack.comp"),
                                                                    include_dirs=[RENDER_DIR], instance=self.instance))
        set_uniforms(pack, _pack_uniforms(n))
        self.opacity.bind_to_image(IMG_DOM, read=False, write=True)
        pack.run(math.ceil(n / 8), math.ceil(n / 8))
        ctx.memory_barrier()
        frame.targets["dom"] = self.opacity

    def strand_step(self, frame: Frame) -> int:
        """The map's own LOD (coverage_lod.light_strand_step, compute path): every m-th expanded
        strand at m times the opacity where the light sees more than 2 ``lod_depth`` strands
        over a texel; kept while the light's view, the settings and the expanded strands are
        the same."""
        r = self.renderer
        expand = r.get_pass("expand")
        s, view = r.settings, frame.light_view
        key = (expand.strands, expand.points)
        memo = self._step
        if memo is not None and memo[0] is view and memo[1] is s and memo[2] == key:
            return memo[3]
        step = 1
        if r.strands is not None and expand.strands > 0:
            widen = r.rendered_strands * len(r.instance_transforms()) / expand.strands   # the coverage LOD's
            boxes = r.instance_boxes(r.strand_pad())
            box = (np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0))
            step = light_strand_step(view, self.map_size(), box, expand.strands, r.strands.mean_length(),
                                     mean_width(s) * widen, float(s.lod_depth))
        self._step = (view, s, key, step)
        return step

    def z0_every_strand(self) -> bool:
        """Whether z0 comes from every strand where the layers' dispatch thins them (strand_step)."""
        return Z0_EVERY_STRAND

    def strand_opacity(self, view) -> float:
        """What a strand adds to a texel of the map from ``view`` per unit of its coverage:
        settings.strand_opacity (light 0's map; the extra lights' coarser maps: extra_shadows.py)."""
        return float(self.renderer.settings.strand_opacity)

    def _layer_uniforms(self, frame: Frame) -> tuple:
        """(the layers' ends (m), strand opacity) for the hair's depth range along the light,
        kept while the settings object, the light's view and the range are the same."""
        s, view, depth_range = self.renderer.settings, frame.light_view, frame.hair_depth_range
        memo = self._layers
        if memo is None or memo[0] is not s or memo[1] is not view or memo[2] != depth_range:
            lo, hi = depth_range
            ext = max(hi - lo, 1e-4)
            memo = self._layers = (s, view, depth_range, (tuple(float(f) * ext for f in s.dom_layers),
                                                          self.strand_opacity(view)))
        return memo[3]

    def read(self) -> np.ndarray:
        """(n, n, 4) float32: O1, O2, O3, z0."""
        return read_f32(self.opacity)

    def owned(self) -> tuple:
        return (self.opacity_fbo, self.opacity, *(self._counters or ()))

    def release(self) -> None:
        super().release()
        self._counters = None


def scan_light_depths(renderer, view, n: int, dom_pass: int, layer_ends=(1.0, 2.0, 3.0),
                      strand_opacity: float = 0.0, balance: int | None = None, programs: ProgramMemo = None,
                      strand_step: int = 1, instance=None) -> None:
    """One dom_raster.comp dispatch over the expanded strands into an n x n light map (the
    buffers at B_DOM_Z0 and, for pass 1, B_DOM_LAYERS bound by the caller): pass 0 the
    nearest light depth bits per texel (atomic min), pass 1 the opacity layers. ``balance``: the
    scan-conversion form (None: raster_segment.balance_for's); ``programs``: the calling pass's
    ProgramMemo, which keeps the kernel (else it is looked up in the shader cache);
    ``strand_step`` m: every m-th strand, its opacity x m; ``instance``: the caller's own program
    object (gpu.glsl.compute_shader)."""
    ctx = renderer.ctx
    defines = raster_defines(ctx, balance)
    defines.update(subgroup_defines(ctx, defines["RASTER_BALANCE"]))

    def build():
        return compute_shader(ctx, shader_path("dom_raster.comp"), {"DOM_PASS": dom_pass, **defines},
                              include_dirs=[RENDER_DIR], instance=instance)

    cs = build() if programs is None else programs.get(("dom_raster", dom_pass, *defines.values()), (), build)
    set_view(cs, view)
    set_uniforms(cs, _scan_uniforms(int(n), layer_ends, strand_opacity, int(strand_step)))
    renderer.get_pass("expand").dispatch_segments(cs, strand_step)
    ctx.memory_barrier()


@functools.lru_cache(maxsize=32)
def _scan_uniforms(n: int, layer_ends: tuple, strand_opacity: float, strand_step: int) -> dict:
    """scan_light_depths' uniforms, one dict per value (set_uniforms skips them by identity)."""
    return {"u_raster_size": (n, n), "u_grid": 1, "u_dom_layers_abs": tuple(float(x) for x in layer_ends),
            "u_strand_opacity": float(strand_opacity) * strand_step, "u_strand_step": int(strand_step)}


@functools.lru_cache(maxsize=8)
def _pack_uniforms(n: int) -> dict:
    return {"u_size": int(n), "u_far": float(FAR)}
