"""The hair drawn by compute shaders instead of the raster units (settings.rasterizer).

Datacentre GPUs such as the H100/H200 keep only a few of their SMs' raster and ROP units, so
thin strands drawn as triangles are bound by a fraction of the chip; scan-converting them in
compute shaders uses all of it (Unreal's and Frostbite's strand rasterisers do the same for
thin hair). Per frame, after the head has been drawn by hardware into the HDR target:

1. ``hair_raster.comp``, one invocation per segment of the expanded strands (passes/expand.py):
   every sample of a ``grid`` x ``grid`` per-pixel sample grid the segment covers
   (raster_segment.glsl) keeps the nearest segment in front of the head (atomic min of depth
   and id: one 64-bit atomic where the GPU has them, else two dispatches of 32-bit ones) and
   adds -log(1 - coverage) to the sample's coverage sum. The scan conversion is load-balanced
   (RASTER_BALANCE): each work group sets up its 128 segments, prefix-sums their sample
   columns in shared memory and deals the columns to its threads, so that a close-up's long
   segments (tens to hundreds of columns) do not leave a warp waiting on its longest one; the
   per-sample buffers are bit-identical to one thread walking its own segment (the atomics
   commute). On the H200 this took a 100k-strand close-up's scan from 23.4 to 8.6 ms; CPU
   rasterisers keep the per-thread form, 3-4x faster there (raster_segment.py). On GPUs the
   form of a frame is the renderer's tuner's (scan_form.py, site ``hair``: the whole section
   below timed in both forms, with the culls each form brings, and the faster kept), since
   the per-thread form wins where segments are short and alike (a crowd of small heads). A third
   form, tiled (raster_tiles.py: segments binned to 16 x 16-sample tiles, each tile's visits in
   shared memory, the 32-bit path's id pass folded in), is the tuner's third choice here, meant
   for pixel-heavy close-ups; the same buffers bit for bit. Head culling
   (depth_tiles.py; ``depth_tiles`` section, a few microseconds): first a tile map of the head's
   depth, the max over each tile of about 8 x 8 pixels; then a segment whose bounding box lies at
   or behind the map at its nearest depth gets no columns, and a column (constant depth) at or
   behind the tiles it touches is skipped: the samples they hold would all fail the per-sample
   depth test, so the buffers are bit-identical (``count_samples``' ``sample_culled``). Hair
   self-occlusion culling (occlusion_tiles.py, on GPUs): the segments split by depth into two
   dispatches, the near ones first; then a tile map of what they hide (``occlusion_tiles``
   section: per sample the head's depth, or the next float past the nearest hair's where the
   coverage has saturated), against which the far segments and columns are culled the same way:
   a visit skipped there would lose the depth min and skip the saturated coverage add, so the
   buffers stay bit-identical.
2. ``hair_shade.comp``, one thread per pixel: each sample's nearest segment shaded at the
   sample's point on it (the hair BSDF of the fragment path, hair_radiance.glsl; equal ids in a
   pixel shaded once), alpha 1 - exp(-coverage sum) over the head and background, the samples
   averaged into the HDR image; the samples hair reached are reset for the next frame as they
   are read (the others are already empty, and a pixel with none is not written).

What differs from the hardware path: every strand behind the nearest one in a sample darkens
it by its coverage but shows its colour only through the nearest's (as in Unreal's
visibility buffer). With MSAA the head is drawn multisampled and resolved (colour and depth)
before the hair is scan-converted against it (Renderer.hdr_textures).
"""
from __future__ import annotations

import math
import re

import numpy as np

from ...gpu.buffers import as_device, check_allocation
from ...gpu.capabilities import has_atomic64  # noqa: F401  (importable from here too)
from ...gpu.clear import fill_words
from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import B_COVER, B_EXPANDED, B_RASTER_STATS, B_VIS, B_VIS_ID, IMG_HDR, IMG_MS, TEX_SCENE_DEPTH
from .base import (shader_path, RENDER_DIR, Frame, Pass, bind_lighting, bounce_defines, set_uniforms, set_view,
                   shadow_defines)
from . import depth_tiles, ms_smooth, occlusion_tiles, raster_tiles
from .raster_segment import TILED, raster_defines, subgroup_defines

STATS_SLOTS = 64    # hair_raster.comp's RASTER_STATS counters
COVER_SCALE = 4096.0    # hair_vis.glsl


def shade_group(grid: int) -> tuple[int, int]:
    """hair_shade.comp's work group in pixels (SHADE_GROUP_X, _Y) at ``grid`` x ``grid`` samples a
    pixel: 16 x 8 up to 2 x 2 samples (H200 at 2 x 2, the default: the 100k close-up 3.96 -> 3.84
    ms against 8 x 8, the target frame 1.235 -> 1.230; one sample a pixel not timed), else 8 x 8,
    so that its job list (16 bytes a sample: id, sample and half-float colour; 20 with the
    multiply scattered light's own colour, MS_SPLIT) stays within the 32 KiB of shared memory
    every GL 4.3 context has."""
    return (16, 8) if grid <= 2 else (8, 8)


# renderer strings of GPUs with few raster units for their size: "auto" picks compute there
FEW_RASTER_UNITS = re.compile(r"\b(H100|H200|H800|H20|GH200|A100|A800|A30|B100|B200|GB200)\b", re.I)


def sample_grid(msaa: int) -> int:
    """Samples per pixel side for an MSAA count: 1 -> 1, 2 and 4 -> 2, 8 -> 3, 16 -> 4."""
    return max(1, math.ceil(math.sqrt(int(msaa)) - 1e-9))


def wants_compute(settings, renderer_string: str) -> bool:
    """Whether settings.rasterizer asks for the compute rasteriser on this GPU."""
    r = settings.rasterizer
    if r == "auto":
        return auto_picks_compute(renderer_string)
    return r == "compute"


def auto_picks_compute(renderer_string: str) -> bool:
    """rasterizer="auto": the compute rasteriser on GPUs with few raster units for their size
    and on CPU rasterisers (llvmpipe: it shades a pixel once per visible segment where the raster
    units shade every fragment of every layer; the default frame at 960 x 540 0.54 s against
    13.6 s, docs/performance.md), the raster units elsewhere."""
    from ...gpu.context import is_software_name

    return bool(FEW_RASTER_UNITS.search(renderer_string or "")) or is_software_name(renderer_string)


def auto_rasterizer(ctx) -> str:
    """What rasterizer="auto" picks on ``ctx``'s GPU: "compute" or "hardware"."""
    from ...gpu.context import renderer_name

    return "compute" if auto_picks_compute(renderer_name(ctx)) else "hardware"


class HairComputePass(Pass):
    name = "hair_compute"
    reads = ("expanded", "hdr", "shadow_map", "dom")
    writes = ("hdr",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.vis64 = has_atomic64(self.ctx)
        self._programs = ProgramMemo()
        self._common = None   # (what _common_uniforms were made of, the uniforms)
        self._steps: dict = {}   # split side -> (split depth, _step_uniforms)
        self._buffers: tuple = ()
        self._key = None
        self.capture = False       # True: keep each frame's visibility (read_capture) before shading
        self.captured = None
        self.count_stats = False   # True: hair_raster.comp counts its samples (RASTER_STATS); see count_samples
        self.raster_stats = None
        self.after_raster: list = []   # callables (frame) run on the filled sample buffers (render/aux_maps.py)
        self.tiles = depth_tiles.DepthTiles(self.ctx)   # the head's depth tile map (head culling)
        self.occlusion = occlusion_tiles.OcclusionTiles(self.ctx)   # the near hair's (hair culling)
        self.raster_tiles = raster_tiles.RasterTiles(self.ctx)      # the tiled form's lists

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.strands is not None and r.compute_raster and r.settings.oit == "none"

    # ------------------------------------------------------------------ buffers
    def sample_size(self) -> tuple[int, int]:
        w, h = self.renderer.settings.render_size
        g = self.renderer.raster_grid
        return w * g, h * g

    def _ensure_buffers(self) -> None:
        w, h = self.sample_size()
        key = (w, h, self.vis64)
        if key == self._key:
            return
        self._release_buffers()
        n = w * h
        ctx = self.ctx
        words = [(B_VIS, 8 if self.vis64 else 4, 0xFFFFFFFF), (B_COVER, 4, 0)]
        if not self.vis64:
            words.append((B_VIS_ID, 4, 0))
        bufs = []
        for binding, size, fill in words:
            check_allocation(ctx, n * size, f"the compute rasteriser's per-sample buffer ({w}x{h} samples)")
            buf = as_device(ctx.buffer(reserve=n * size))
            fill_words(ctx, buf, fill, self._programs)   # the shading pass keeps it so
            bufs.append((binding, buf))
        self._buffers = tuple(bufs)
        self._key = key

    def bytes(self) -> int:
        return sum(b.size for _, b in self._buffers) + self.raster_tiles.bytes()

    # ------------------------------------------------------------------ frame
    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        expand = r.get_pass("expand")
        expand.ensure()
        self._ensure_buffers()
        for binding, buf in self._buffers:
            buf.bind_to_storage_buffer(binding)
        color, depth = r.hdr_textures()
        grid = r.raster_grid
        size = self.sample_size()
        common = self._common_uniforms(size, grid, expand.points)
        defines = {"VIS64": int(self.vis64)}
        stats = self._stats_buffer() if self.count_stats else None
        # the form of this frame: the hair site's tuner's (scan_form.py), which times everything
        # from the head's tile map to the last raster dispatch; a counting frame keeps its choice
        site = r.scan_forms.hair
        if stats is None:
            form = site.begin(r.settings, (expand.segments, 1 if r.instances is None else len(r.instances)))
        else:
            form = site.current()
        balance = {**raster_defines(ctx, form), **subgroup_defines(ctx, form)}
        tiled = balance["RASTER_BALANCE"] == TILED
        cull = depth_tiles.cull_defines(ctx, form)
        hair_cull = occlusion_tiles.hair_cull(ctx, form)
        if hair_cull:   # both maps: segments and columns
            cull = {"RASTER_HEAD_CULL": 1, "RASTER_CULL_SPANS": 1, "RASTER_CULL_COLUMNS": 1}
        if tiled:   # the bin culls segments against the map; columns by the tile's own bounds
            cull = {**cull, "RASTER_CULL_COLUMNS": 0}
        if cull["RASTER_HEAD_CULL"]:
            with r.profiler.section("depth_tiles"):
                self.tiles.update(depth, grid)
        # (RASTER_PASS, split side, tile map or None): one dispatch a pass, or with the hair cull
        # the near segments against the head's map, the occlusion map, the far ones against it
        head_map = self.tiles if cull["RASTER_HEAD_CULL"] else None
        # (the tiled form's steps resolve the 32-bit path's ids themselves: no id pass)
        one_pass = self.vis64 or tiled
        if hair_cull:
            steps = [(0, 1, self.tiles), "occlusion", (0, 2, self.occlusion)]
            if not one_pass:
                steps.append((1, 0, self.occlusion))
            split = occlusion_tiles.split_depth(r, frame.view)
        else:
            steps = [(p, 0, head_map) for p in ((0,) if one_pass else (0, 1))]
            split = 0.0
        with r.profiler.section("hair_raster"):
            for step in steps:
                if step == "occlusion":
                    bufs = dict(self._buffers)
                    with r.profiler.section("occlusion_tiles"):
                        self.occlusion.update(depth, grid, bufs[B_VIS], bufs[B_COVER], self.vis64)
                    continue
                raster_pass, side, tiles = step
                if tiled:
                    self._tiled_step(frame, side, tiles, split, common, cull, stats is not None)
                    continue
                cs = self._programs.get(("raster", raster_pass, stats is not None),
                                        (*balance.values(), *cull.values()),
                                        lambda: compute_shader(ctx, shader_path("hair_raster.comp"), {
                                            **defines, **balance, **cull, "RASTER_PASS": raster_pass,
                                            **({"RASTER_STATS": 1} if stats is not None else {})},
                                            include_dirs=[RENDER_DIR]))
                groups = self._bind_step(cs, frame, common, depth, side, split, tiles)
                if groups is not None:
                    cs.run(*groups)
                ctx.memory_barrier()
        site.end()
        if stats is not None:
            self.raster_stats = self._read_stats(stats)
        if self.capture:
            self.captured = self._read_buffers()
        for hook in self.after_raster:
            hook(frame)
        with r.profiler.section("hair_shade"):
            bounce = bounce_defines(r)
            split = int(ms_smooth.active(r))   # the multiply scattered light to a target of its own
            gx, gy = shade_group(grid)
            cs = self._programs.get("shade", (r.shading, r.settings, bounce["SKIN_BOUNCE"], bounce.get("SKIN_BOUNCE_GRID"),
                                              grid, split), lambda: compute_shader(
                ctx, shader_path("hair_shade.comp"), {**defines, **r.shading.defines(), **shadow_defines(ctx, r.settings),
                                                       **bounce, "SHADE_GRID": int(grid), "SHADE_GROUP_X": gx,
                                                       "SHADE_GROUP_Y": gy, "MS_SPLIT": split},
                include_dirs=[RENDER_DIR]))
            set_view(cs, frame.view)
            set_uniforms(cs, common)
            expand.buffer.bind_to_storage_buffer(B_EXPANDED)
            r.shading.bind(cs, ctx, r.settings)
            bind_lighting(r, cs, frame)
            if split:   # (cleared first: the clear binds its own image unit)
                r.get_pass("ms_smooth").target().bind_to_image(IMG_MS, read=False, write=True)
            color.bind_to_image(IMG_HDR, read=True, write=True)
            w, h = r.settings.render_size
            cs.run(math.ceil(w / gx), math.ceil(h / gy))
            ctx.memory_barrier()

    def _bind_step(self, cs, frame, common: dict, depth, side: int, split: float, tiles):
        """A raster step's kernel ready to run: the view, the uniforms, the head's depth, the
        step's cull map and the expanded segments; the work groups of one a segment (None: none)."""
        set_view(cs, frame.view)
        set_uniforms(cs, common)
        depth.use(TEX_SCENE_DEPTH)
        set_uniforms(cs, self._step_uniforms(side, split))
        if tiles is not None:
            tiles.bind(cs)
        return self.renderer.get_pass("expand").bind_segments(cs)

    def _tiled_step(self, frame, side: int, tiles, split: float, common: dict, cull: dict, stats: bool) -> None:
        """One raster step in the tiled form (raster_tiles.py): the bin's count, the lists' scan,
        the scatter, the tiled raster over the non-empty tiles (indirect), and the balanced form's
        dispatches (indirect: none of their work groups unless the lists overflowed). ``tiles``
        the step's cull map (None: no cull), ``side`` its side of the depth split."""
        r, ctx = self.renderer, self.ctx
        expand = r.get_pass("expand")
        rt = self.raster_tiles
        rt.prepare(self.sample_size(), expand.segments)
        _, depth = r.hdr_textures()
        base = {"VIS64": int(self.vis64), **({"RASTER_STATS": 1} if stats else {})}

        def program(name, defines):
            return self._programs.get((name, stats), tuple(defines.values()), lambda: compute_shader(
                ctx, shader_path("hair_raster.comp"), {**base, **defines}, include_dirs=[RENDER_DIR]))

        def begin(cs):
            return self._bind_step(cs, frame, common, depth, side, split, tiles)

        def tiled(phase):
            cs = program(("tiled", phase), {"RASTER_BALANCE": TILED, **cull, "RASTER_PASS": 0,
                                            "RASTER_TILED_PHASE": phase, **raster_tiles.defines(ctx)})
            groups = begin(cs)
            if groups is not None:
                rt.bind(cs)
            return cs, groups

        for phase in (1, 2):
            cs, groups = tiled(phase)
            if groups is None:   # no segments
                return
            cs.run(*groups)
            ctx.memory_barrier()
            if phase == 1:
                rt.scan(groups)
        # the balanced form where the lists overflowed (the 32-bit path's depths clearing the
        # ids an earlier step left, then its id pass): the same buffers, slower. It runs before
        # the tiled raster with no barrier between them: the scan gives work groups to one of
        # the two, never both (an empty dispatch's barrier cost ~8 us, H200)
        fallback_cull = {"RASTER_HEAD_CULL": int(tiles is not None), "RASTER_CULL_SPANS": 1, "RASTER_CULL_COLUMNS": 1}
        passes = (0,) if self.vis64 else (0, 1)
        for raster_pass in passes:
            reset = {"RASTER_RESET_ID": 1} if not self.vis64 and raster_pass == 0 else {}
            cs = program(("fallback", raster_pass), {"RASTER_BALANCE": 1, **fallback_cull, "RASTER_PASS": raster_pass,
                                                     **reset})
            begin(cs)
            rt.dispatch_fallback(cs)
            if raster_pass != passes[-1]:
                ctx.memory_barrier()
        cs, _ = tiled(3)
        rt.dispatch_tiles(cs)
        ctx.memory_barrier()

    # ------------------------------------------------------------------ statistics
    def count_samples(self, camera=None, lights=None) -> dict:
        """Render one frame with hair_raster.comp's counters on (RASTER_STATS; the normal
        shaders have none): ``sample_visits`` (samples the segments scan-convert), ``sample_writes``
        (those in front of the head, each an atomic min and a coverage add; with the hair cull
        less those it skipped, which were no-ops), ``sample_culled`` (of
        the visits, those skipped whole columns at a time behind the head's depth tile map,
        depth_tiles.py, or the near hair's, occlusion_tiles.py; 0 with the culls off), ``raster_atomics`` (every atomic on the per-sample
        buffers: 2 per write, and on the 32-bit path the id pass's atomicMax) and
        ``raster_atomic_bits`` (64: the depth-and-id min is one 64-bit atomic)."""
        self.count_stats, self.raster_stats = True, None
        try:
            self.renderer.render(camera, lights)
        finally:
            self.count_stats = False
        return dict(self.raster_stats or {})

    def _stats_buffer(self):
        buf = self.ctx.buffer(reserve=STATS_SLOTS * 16)
        buf.write(bytes(STATS_SLOTS * 16))
        buf.bind_to_storage_buffer(B_RASTER_STATS)
        return buf

    def _read_stats(self, buf) -> dict:
        c = np.frombuffer(buf.read(), np.uint32).reshape(STATS_SLOTS, 4).astype(np.uint64).sum(axis=0)
        buf.release()
        scanned, written, id_atomics, culled = (int(v) for v in c[:4])
        return {"sample_visits": scanned, "sample_writes": written, "sample_culled": culled,
                "raster_atomics": 2 * written + id_atomics,
                "raster_atomic_bits": 64 if self.vis64 else 32}

    def _read_buffers(self) -> dict:
        """The sample grid's nearest segment (first point's index into the expanded strands, -1:
        none) and coverage sum -sum(log(1 - c)), each (height x grid, width x grid)."""
        w, h = self.sample_size()
        bufs = dict(self._buffers)
        if self.vis64:
            v = np.frombuffer(bufs[B_VIS].read(), np.uint64)
            ids = (v & np.uint64(0xFFFFFFFF)).astype(np.int64)
            ids[ids == 0xFFFFFFFF] = -1
        else:
            ids = np.frombuffer(bufs[B_VIS_ID].read(), np.uint32).astype(np.int64) - 1
        cover = np.frombuffer(bufs[B_COVER].read(), np.uint32) / COVER_SCALE
        g = self.renderer.raster_grid

        def grid(a):   # pixel-major (hair_vis.glsl's sample_index) -> rows of samples
            return a.reshape(h // g, w // g, g, g).transpose(0, 2, 1, 3).reshape(h, w)

        return {"ids": grid(ids), "cover": grid(cover)}

    def _common_uniforms(self, size, grid: int, points: int) -> dict:
        """The raster and shade kernels' common uniforms (besides the view's): one dict while
        they stay the same, so that set_uniforms skips it."""
        key = (size, grid, self.renderer.settings.geometry == "lines", points)
        memo = self._common
        if memo is None or memo[0] != key:
            memo = self._common = (key, {"u_raster_size": tuple(int(v) for v in size), "u_grid": int(grid),
                                         "u_lines": int(key[2]), "u_points_per_strand": int(points)})
        return memo[1]

    def _step_uniforms(self, side: int, split: float) -> dict:
        """A raster dispatch's own uniforms (the scene depth's unit, which side of the split it
        draws), one dict per side while the split depth is the same."""
        memo = self._steps.get(side)
        if memo is None or memo[0] != split:
            memo = self._steps[side] = (split, {"u_scene_depth": TEX_SCENE_DEPTH, "u_split_side": side,
                                                "u_split_depth": split})
        return memo[1]

    def _release_buffers(self) -> None:
        for _, b in self._buffers:
            b.release()
        self._buffers = ()
        self._key = None

    def release(self) -> None:
        self._release_buffers()
        self.tiles.release()
        self.occlusion.release()
        self.raster_tiles.release()


def unsupported_reason(renderer) -> str | None:
    """Why the compute rasteriser cannot draw with the renderer's settings (None: it can)."""
    from ..oit.compute import COMPUTE_METHODS

    s = renderer.settings
    if s.pipeline != "compute":
        return "the compute rasteriser needs pipeline='compute'; the hair is drawn by hardware"
    oit = s.oit
    if oit != "none" and oit not in COMPUTE_METHODS:
        return (f"the OIT method {oit!r} has no compute form (those with one: {', '.join(COMPUTE_METHODS)}); "
                "the hair is drawn by hardware")
    return None
