"""The tiled scan conversion of the compute rasteriser (raster_segment.py's form 2, "tiled"; the
hair raster only): the buffers and dispatches of one step (hair_compute.py: a step is the whole
raster, or each side of the hair cull's depth split).

In a close-up the balanced form is bound by sample visits (the H200's 100k-strand close-up:
~137 visits per covered sample, 684M a frame, nearly all global-memory reads of a sample whose
coverage has saturated or whose nearest hair is nearer). Here the visits go to shared memory:

1. hair_raster.comp, RASTER_TILED_PHASE 1: a thread a segment (set up, split and culled against
   the bound tile map as in the other forms) counts itself into every screen tile of
   ``1 << TILE_SHIFT`` samples a side its columns may touch (a superset, never fewer), through a
   work group's shared table (raster_tiles.glsl);
2. raster_tiles_scan.comp (three dispatches): the counts' exclusive scan into list offsets, the
   scatter's cursors, the non-empty tiles and two indirect dispatches;
3. RASTER_TILED_PHASE 2: the same walk writes each segment's first point into its tiles' lists
   (at the rank its count took in the group's shared table);
4. RASTER_TILED_PHASE 3, a work group of 256 threads per non-empty tile (indirect): the tile's depth, id,
   coverage and head depth loaded into shared memory, its segments' columns clipped to the
   tile and dealt to the threads, the depth min and coverage add done there (walk 1), the ids
   by a second walk (the 32-bit path's id pass folded in; VIS64's min id at the min depth
   without 64-bit shared atomics), the tile written back; per 8 x 8 samples a bound past which
   a visit is a no-op (head, saturated coverage) culls columns and entries in shared memory.

Each sample is visited with the same depth and coverage as in the other forms
(raster_column_range, rows clipped to the tile), so the buffers are bit-identical
(tests/test_render_compute_tiled.py). The lists hold ``capacity`` entries (ENTRIES_PER_SEGMENT a
segment, grown to GROWTH x the largest total seen, copied every CHECK_EVERY steps and read once the GPU is past the copy, never waiting); a step
whose entries pass it runs the balanced form instead (the scan gives its indirect dispatch the
work groups and the tiled raster none), so an overflow costs time, never exactness.
"""
from __future__ import annotations

import numpy as np

from ...gpu import replay as gl_replay
from ...gpu.buffers import as_device, check_allocation
from ...gpu.capabilities import get_capabilities
from ...gpu.fence import Fence
from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import B_TILE_COUNTS, B_TILE_ENTRIES, B_TILE_INDEX
from . import raster_segment
from .base import set_uniforms, shader_path

TILE_SHIFT = 4           # a tile: 16 x 16 samples (H200, 1080p: the 100k close-up 7.35 ms against 9.15 at 32 x 32
                         # and 9.59 at 8 x 8; the 1M close-up 14.18 / 16.61 / 24.75; docs/performance.md)
# the index buffer's words (raster_tiles.glsl, raster_tiles_scan.comp): the tiled raster's and
# the balanced fallback's indirect dispatches, the overflow flag, the step's entries, the
# largest seen; from RT_HEADER the offsets (tiles + 1) and the non-empty tiles
INDEX = {"RT_TILED_ARGS": 0, "RT_FALLBACK_ARGS": 4, "RT_OVERFLOW": 8, "RT_TOTAL": 9, "RT_PEAK": 10, "RT_HEADER": 16}
ENTRIES_PER_SEGMENT = 6  # the first capacity: entries a segment (a close-up's touch 2-6 tiles)
MIN_CAPACITY = 1 << 16
MAX_CAPACITY = 1 << 28   # entries (1 GiB), below the scan's saturation (2^30)
GROWTH = 1.25            # capacity past the largest total seen, when it overflowed
PACKED = True            # VIS64: one walk, the tile's (depth, id) words by 64-bit shared atomic min
SCAN_BLOCK = 1024         # tiles a work group of the lists' scan takes (raster_tiles_scan.comp: 4 a thread)
CHECK_EVERY = 16         # steps between copies of the largest total (read once the GPU is past them)
CAPACITY = None          # tests: a fixed capacity in entries (None: by the rule above)


def defines(ctx=None) -> dict:
    """The defines of the programs that include raster_tiles.glsl or run raster_tiles_scan.comp
    (RT_PACKED: raster_tiles.glsl's one walk with 64-bit shared atomics, on when VIS64 is;
    RT_SUBGROUP: the walk's subgroup scan, raster_segment.subgroup_scan(ctx); off without a context)."""
    return {"RT_SHIFT": TILE_SHIFT, "RT_PACKED_OK": int(PACKED), **INDEX,
            "RT_SUBGROUP": int(ctx is not None and raster_segment.subgroup_scan(ctx))}


class RasterTiles:
    """The tiled form's buffers: ``prepare`` sizes them for a step, ``bind`` hands them (and
    their uniforms) to a hair_raster.comp phase, ``scan`` lays the lists out between the bin's
    phases, ``dispatch_tiles`` / ``dispatch_fallback`` run the indirect dispatches."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.counts = self.index = self.entries = None
        self.tiles = (0, 0)
        self.capacity = 0
        self._want = 0            # the capacity asked for (grown on overflow)
        self._steps = 0
        self._pending = None      # the fence of a peak copy not read yet (_check_peak)
        self._staging = None      # the copy's 4 bytes
        self._programs = ProgramMemo()
        self._uniforms = None

    def prepare(self, size, segments: int) -> None:
        """Buffers for a sample grid of ``size`` and ``segments`` segments; every CHECK_EVERY
        steps the largest total is read back and the lists grown past it."""
        w, h = (int(v) for v in size)
        side = 1 << TILE_SHIFT
        tiles = (-(-w // side), -(-h // side))
        n = tiles[0] * tiles[1]
        if CAPACITY is not None:
            want = max(1, int(CAPACITY))
        else:
            want = max(self._want, min(MAX_CAPACITY, max(MIN_CAPACITY, ENTRIES_PER_SEGMENT * int(segments) + n)))
            limit = get_capabilities(self.ctx).limits.get("max_shader_storage_block_size")
            if limit:
                want = min(want, int(limit) // 4)
        self._steps += 1
        if CAPACITY is None:
            gl_replay.each_frame(self._quiet_next, self._skip)
        if self.index is not None and CAPACITY is None:
            peak = self._check_peak()
            if peak is not None and peak > self.capacity:
                want = max(want, min(MAX_CAPACITY, int(peak * GROWTH) + 1))
                if limit:
                    want = min(want, int(limit) // 4)
                self._want = want
        if self.index is not None and tiles == self.tiles and want == self.capacity:
            return
        self.release()
        ctx = self.ctx
        check_allocation(ctx, 4 * want, f"the tiled raster's lists ({want} entries)")
        blocks = -(-n // SCAN_BLOCK)
        self.counts = as_device(ctx.buffer(np.zeros(2 * n + 2 * blocks, np.uint32).tobytes()))
        self.index = as_device(ctx.buffer(np.zeros(INDEX["RT_HEADER"] + 2 * n + 1, np.uint32).tobytes()))
        self.entries = as_device(ctx.buffer(reserve=4 * want))
        self.tiles, self.capacity = tiles, want
        self._uniforms = {"u_rt_tiles": tiles, "u_rt_capacity": want}

    def _quiet_next(self) -> bool:
        """Whether the next step neither reads the peak nor copies it (a frame may be played)."""
        return self._pending is None and (self._steps + 1) % CHECK_EVERY != 0

    def _skip(self) -> None:
        self._steps += 1

    def _check_peak(self) -> int | None:
        """The largest total since the buffers were made, read without waiting for the GPU: every
        CHECK_EVERY steps the index's peak word is copied to a small buffer behind a fence, and
        read at the first step after the GPU has passed it (None until then)."""
        if self._pending is not None:
            if not self._pending.done():
                return None
            self._pending = None
            return int(np.frombuffer(self._staging.read(size=4), np.uint32)[0])
        if self._steps % CHECK_EVERY == 0:
            if self._staging is None:
                self._staging = self.ctx.buffer(reserve=4)
            self.ctx.copy_buffer(self._staging, self.index, 4, read_offset=4 * INDEX["RT_PEAK"])
            self._pending = Fence()
        return None

    def bind(self, cs) -> None:
        self.counts.bind_to_storage_buffer(B_TILE_COUNTS)
        self.index.bind_to_storage_buffer(B_TILE_INDEX)
        self.entries.bind_to_storage_buffer(B_TILE_ENTRIES)
        set_uniforms(cs, self._uniforms)

    def scan(self, fallback_groups) -> None:
        """Lay the lists out from the counts (raster_tiles_scan.comp's three dispatches);
        ``fallback_groups`` the balanced form's work groups over every segment
        (expand.bind_segments)."""
        blocks = -(-(self.tiles[0] * self.tiles[1]) // SCAN_BLOCK)
        fallback = {"u_rt_fallback": tuple(int(g) for g in (fallback_groups or (0, 0)))}
        for phase, groups in ((1, blocks), (2, 1), (3, blocks)):
            cs = self._programs.get(("scan", phase), (SCAN_BLOCK,), lambda: compute_shader(
                self.ctx, shader_path("raster_tiles_scan.comp"), {**defines(), "SCAN_PHASE": phase, "SCAN_BLOCK": SCAN_BLOCK}))
            self.bind(cs)
            set_uniforms(cs, fallback)
            cs.run(groups)
            self.ctx.memory_barrier()

    def dispatch_tiles(self, cs) -> None:
        cs.run_indirect(self.index, 4 * INDEX["RT_TILED_ARGS"])

    def dispatch_fallback(self, cs) -> None:
        cs.run_indirect(self.index, 4 * INDEX["RT_FALLBACK_ARGS"])

    def status(self) -> dict:
        """The last step's ``overflow`` (bool) and ``total`` entries, the ``peak`` total since the
        buffers were made, the ``capacity`` (reads the GPU: waits for it)."""
        head = np.frombuffer(self.index.read(size=4 * INDEX["RT_HEADER"]), np.uint32)
        return {"overflow": bool(head[INDEX["RT_OVERFLOW"]]), "total": int(head[INDEX["RT_TOTAL"]]),
                "peak": int(head[INDEX["RT_PEAK"]]), "capacity": self.capacity}

    def bytes(self) -> int:
        return sum(b.size for b in (self.counts, self.index, self.entries) if b is not None)

    def release(self) -> None:
        for b in (self.counts, self.index, self.entries):
            if b is not None:
                b.release()
        self.counts = self.index = self.entries = None
        self.tiles, self.capacity = (0, 0), 0
        if self._pending is not None:   # a copy of buffers now gone
            self._pending.release()
            self._pending = None
        if self._staging is not None:
            self._staging.release()
            self._staging = None
