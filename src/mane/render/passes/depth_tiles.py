"""The head culling of the compute rasteriser: a per-frame tile map of the scene depth.

Most of a frame's sample visits land behind the head (1M strands at the default framing on the
H200: 63% of 1.0G visits, each rejected alone by ``z >= scene depth``). ``depth_tiles.comp``
reduces the head's depth texture (exactly the one the rasteriser tests against:
Renderer.hdr_textures, the resolved MSAA head with ``head_msaa``) to the largest window depth
over each tile of the sample grid (a tile with any background pixel holds the clear's 1.0 and
never culls). The kernels (raster_segment.glsl's RASTER_CULL hook, depth_tiles.glsl) then skip
a segment whose bounding box of samples lies at or behind the map at the segment's nearest depth
(it gets no columns, so in the balanced form none is dealt), and, of the others, a sample column
(along which depth and coverage are constant) at or behind the tiles it touches: every sample
they hold would fail its own test (``z >= depth``, and the tile's max is at least the depth of
each of its pixels), so the per-sample buffers stay bit-identical
(tests/test_render_compute_headcull.py).

A tile is ``TILE`` = 8 pixels a side, as samples rounded up to a power of two (grid 1: 8
samples, 2 x 2: 16, 3 x 3 and 4 x 4: 32), so that a kernel finds a sample's tile by a shift (an
integer division by the grid, per column, made the scan 1.3x slower on llvmpipe, where the
divides of the SIMD lanes are scalar). 8 pixels: a column spans a few samples across (about a
pixel), so it touches one tile, two at a tile edge, whatever the tile size; a smaller tile
follows the head's silhouette and the slope of its depth more closely (hair on the far side of
the scalp is only centimetres behind the near side), and the map stays small (1080p: 240 x 135
floats, 127 KB, in L2 all frame); a segment's box at the default framing (a few pixels) touches
1-4 tiles, and one touching more than 32 (depth_tiles.glsl) is left to its columns
(``headcull.py --tile 16`` measures the other choice).

Columns are culled with the balanced scan conversion (GPUs: raster_segment.py; the frame's form
is the hair site's tuner's, scan_form.py; the OIT fill keeps the fixed rule), where a warp's
lanes take neighbouring columns and skip them together; in the per-thread form (CPU
rasterisers) a lane's skipped column saves nothing while its neighbours walk their own
segments', and the check made the scan 1.1-1.3x slower on llvmpipe (960x540, the scale
section's quick stand-ins), where the segment cull alone made it 1.06-1.18x faster.
``HEAD_CULL`` (read each frame) overrides the choice: tests and the A/B script
(gpu-scripts/headcull.py) set it.
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu.buffers import as_device
from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import B_DEPTH_TILES, TEX_SCENE_DEPTH
from .base import set_uniforms, shader_path
from .raster_segment import balance_for

TILE = 8           # pixels a tile side (a power of two)
# RASTER_HEAD_CULL, read each frame: None, by the renderer (segments always, columns with the
# balanced scan conversion); True, segments and columns; False, off; "segments" or "columns" alone
HEAD_CULL = None
CULL_PARTS = {True: (1, 1), False: (0, 0), "segments": (1, 0), "columns": (0, 1)}


def cull_defines(ctx, balance: int | None = None) -> dict:
    """The defines of the kernels that cull against the tile map (hair_raster.comp, oit_raster.comp);
    ``balance`` the scan-conversion form they run (None: raster_segment.balance_for's)."""
    key = HEAD_CULL if HEAD_CULL is None or isinstance(HEAD_CULL, str) else bool(HEAD_CULL)
    if key is None:
        spans, columns = 1, int(bool(balance_for(ctx) if balance is None else balance))
    elif key in CULL_PARTS:
        spans, columns = CULL_PARTS[key]
    else:
        raise ValueError(f"depth_tiles.HEAD_CULL must be None, True, False, 'segments' or 'columns', not {HEAD_CULL!r}")
    return {"RASTER_HEAD_CULL": int(spans or columns), "RASTER_CULL_SPANS": spans, "RASTER_CULL_COLUMNS": columns}


def tile_shift(grid: int) -> int:
    """log2 of a tile's side in samples at ``grid`` x ``grid`` samples a pixel: TILE pixels,
    rounded up to a power of two samples."""
    if TILE < 1 or TILE & (TILE - 1):
        raise ValueError(f"depth_tiles.TILE must be a power of two, not {TILE}")
    return (TILE - 1).bit_length() + (int(grid) - 1).bit_length()


class DepthTiles:
    """The tile map's buffer: ``update`` fills it from a depth texture, ``bind`` hands it to a
    kernel that includes depth_tiles.glsl."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.buffer = None
        self.tiles = (0, 0)   # across, down
        self.shift = 0        # log2 of a tile's side in samples
        self._programs = ProgramMemo()
        self._layout = None   # ((depth size, grid, TILE), update's uniforms, bind's uniforms)

    def update(self, depth, grid: int = 1) -> None:
        """Reduce ``depth`` (a single-sample depth texture, a pixel ``grid`` x ``grid`` samples
        of the rasteriser) into the map (one dispatch)."""
        cs = self._programs.get("tiles", (), lambda: compute_shader(self.ctx, shader_path("depth_tiles.comp")))
        tiles = self._begin(cs, depth, grid)
        cs.run(math.ceil(tiles[0] / 8), math.ceil(tiles[1] / 8))
        self.ctx.memory_barrier()

    def _begin(self, cs, depth, grid: int) -> tuple:
        """Size the map for ``depth`` at ``grid`` samples a pixel side and set ``cs``'s common
        uniforms (the depth texture, the tile counts and shift, the sample grid's size); the tile
        counts. The layout and its uniforms are made again when the depth's size or grid changes."""
        key = (depth.size, grid, TILE)
        if self._layout is None or self._layout[0] != key or self.buffer is None:
            w, h = depth.size
            shift = tile_shift(grid)
            side = 1 << shift
            tiles = (-(-w * grid // side), -(-h * grid // side))
            if self.buffer is None or tiles != self.tiles:
                self.release()
                self.buffer = as_device(self.ctx.buffer(reserve=4 * tiles[0] * tiles[1]))
                self.tiles = tiles
            self.shift = shift
            bind = {"u_depth_tiles": tiles, "u_tile_shift": shift}
            self._layout = (key, {**bind, "u_scene_depth": TEX_SCENE_DEPTH, "u_grid": int(grid),
                                  "u_raster_size": (w * grid, h * grid)}, bind)
        depth.use(TEX_SCENE_DEPTH)
        set_uniforms(cs, self._layout[1])
        self.buffer.bind_to_storage_buffer(B_DEPTH_TILES)
        return self.tiles

    def bind(self, cs) -> None:
        self.buffer.bind_to_storage_buffer(B_DEPTH_TILES)
        set_uniforms(cs, self._layout[2])

    def read(self) -> np.ndarray:
        """The map, (tiles down, tiles across) float32."""
        return np.frombuffer(self.buffer.read(), np.float32).reshape(self.tiles[1], self.tiles[0]).copy()

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
        self.buffer = None
        self.tiles = (0, 0)
        self._layout = None
