"""The hair self-occlusion cull of the compute rasteriser: a tile map of what the near hair hides.

In a close-up most sample visits are no-ops: each covered sample is visited by tens of strands,
mostly behind a sample whose coverage has already saturated (COVER_SATURATED, alpha 1 - e^-12)
under nearer hair, so the visit loses the depth min and skips the coverage add, yet still costs
its loads. hair_compute.py therefore splits hair_raster.comp's dispatch in two by depth:

1. the segments whose nearest window depth lies in front of ``split_depth`` (``SPLIT`` of the
   way through the hair's view-depth range; both dispatches run the same program and test the
   same expression, so every segment lands in exactly one), culled against the head's map
   (depth_tiles.py);
2. ``occlusion_tiles.comp``: per tile of the sample grid (depth_tiles' tiles), the max over its
   samples of ``min(head depth, saturated ? next float past the nearest hair depth : 1.0)``;
3. the other segments, segments and columns culled against that map with depth_tiles.glsl's
   rule ``z >= map`` (raster_segment.glsl's RASTER_CULL).

Why the buffers stay bit-identical: a culled column's z is at or past every sample's threshold,
so at each sample either ``z >= head depth`` (the visit's own test fails) or the sample had
saturated after dispatch 1 with ``z > nearest hair depth`` (the next float: strictly further;
a tied depth may still win the 64-bit min by its id bits). The buffers only evolve monotonically
(depth falls, coverage rises), so in dispatch 2, however its atomics interleave, the visit's
depth min loses and its coverage add is skipped: a no-op. On the 32-bit path (no 64-bit
atomics) the id pass runs over every segment against the same map: a culled z is past the
depth after dispatch 1, which is at or past the final one, so it never equals the final depth
the id pass looks for. Thresholds below the smallest normal float (a depth at the near plane)
are left at 1.0 (no hair cull), so a GPU flushing denormals cannot cull a tie.
(tests/test_render_compute_haircull.py.)

``HAIR_CULL`` (read each frame): None, by the renderer (with the balanced scan conversion, and
in the per-thread form where ``PER_THREAD``; the frame's form is the hair site's tuner's,
scan_form.py, which times each form with its culls); True, on; False, off. On, the head's map is used in
dispatch 1 whatever depth_tiles.HEAD_CULL says (the A/B of the head cull alone: HAIR_CULL False).
"""
from __future__ import annotations

import numpy as np

from ...gpu.glsl import compute_shader
from ..bindings import B_COVER, B_VIS
from ..coverage_lod import box_corners
from .base import RENDER_DIR, same_box, shader_path
from .depth_tiles import DepthTiles
from .raster_segment import balance_for

SPLIT = 0.35        # where the first dispatch ends, of the way from the hair's nearest depth to its furthest
HAIR_CULL = None    # None: by the renderer; True: on; False: off
PER_THREAD = False  # on by default in the per-thread scan conversion (CPU rasterisers) too


def hair_cull(ctx, balance: int | None = None) -> bool:
    """Whether this frame splits the raster dispatch and culls the far part by the near hair;
    ``balance`` the scan-conversion form (None: raster_segment.balance_for's)."""
    if HAIR_CULL is None:
        return bool((balance_for(ctx) if balance is None else balance) or PER_THREAD)
    if isinstance(HAIR_CULL, (bool, np.bool_)):
        return bool(HAIR_CULL)
    raise ValueError(f"occlusion_tiles.HAIR_CULL must be None, True or False, not {HAIR_CULL!r}")


def split_depth(renderer, view) -> float:
    """The window depth between the two dispatches: ``SPLIT`` of the way through the hair's view
    depth range (its box padded as the OIT methods pad it: oit/base.py), projected by ``view``;
    kept on the (kept) view while the hair's box, the pad and SPLIT are the same."""
    box = renderer.hair_bbox()
    key = (renderer.strand_pad() + float(renderer.settings.width), SPLIT)
    memo = view.__dict__.get("_split_depth")
    if memo is not None and same_box(memo[0], box) and memo[1] == key:
        return memo[2]
    out = _split_depth(box, key[0], view)
    view.__dict__["_split_depth"] = (box, key, out)
    return out


def _split_depth(box, pad: float, view) -> float:
    lo, hi = box
    corners = box_corners(np.asarray(lo, float) - pad, np.asarray(hi, float) + pad)
    fwd = np.asarray(view.forward, float)
    d = (corners - np.asarray(view.eye, float)) @ fwd
    dist = float(d.min()) + SPLIT * float(d.max() - d.min())
    c = np.asarray(view.view_proj, float) @ np.r_[np.asarray(view.eye, float) + dist * fwd, 1.0]
    if not c[3] > 1e-12:   # the split behind the eye: everything in the second dispatch
        return 0.0
    return float(c[2] / c[3] * 0.5 + 0.5)


class OcclusionTiles(DepthTiles):
    """The map's buffer: ``update`` fills it from the head's depth and the per-sample buffers,
    ``bind`` hands it to a kernel that includes depth_tiles.glsl (in the head map's place)."""

    def update(self, depth, grid: int, vis, cover, vis64: bool) -> None:
        """One dispatch over the tiles: ``depth`` the head's texture (pixels), ``vis`` and
        ``cover`` the per-sample buffers (hair_vis.glsl; with ``vis64`` the 64-bit words)."""
        cs = self._programs.get(("occlusion", bool(vis64)), (), lambda: compute_shader(
            self.ctx, shader_path("occlusion_tiles.comp"), {"VIS64": int(bool(vis64))},
            include_dirs=[RENDER_DIR]))
        tiles = self._begin(cs, depth, grid)   # u_raster_size too
        vis.bind_to_storage_buffer(B_VIS)
        cover.bind_to_storage_buffer(B_COVER)
        cs.run(tiles[0], tiles[1])   # a work group a tile
        self.ctx.memory_barrier()
