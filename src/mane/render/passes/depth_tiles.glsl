// The scene depth's tile map as the compute rasteriser reads it (depth_tiles.py, filled by
// depth_tiles.comp): per DEPTH_TILE x DEPTH_TILE tile of pixels the largest window depth of the
// head's depth texture. A window depth z at or behind the max of every tile that a box of pixels
// touches is at or behind every pixel's depth there, so each per-pixel test `z >= depth` in the
// box would fail: the kernels skip the box's samples at once (RASTER_COLUMN_CULL).
layout(std430, binding = B_DEPTH_TILES) readonly buffer DepthTiles { float depth_tiles[]; };
uniform ivec2 u_depth_tiles;   // tiles across and down
// the most tiles looked at for one box (a column spans <= 2 RASTER_MAX_SPAN + 1 samples: 18
// tiles of 8 at one sample a pixel); a box touching more is not culled
#define DEPTH_TILES_MAX_TOUCHED 32

// whether z is at or behind the scene in every pixel of the box p0..p1 (inclusive, in the
// texture); false for a NaN z
bool depth_tiles_behind(ivec2 p0, ivec2 p1, float z) {
    ivec2 t0 = p0 / DEPTH_TILE;
    ivec2 t1 = min(p1 / DEPTH_TILE, u_depth_tiles - 1);
    if ((t1.x - t0.x + 1) * (t1.y - t0.y + 1) > DEPTH_TILES_MAX_TOUCHED) return false;
    for (int ty = t0.y; ty <= t1.y; ++ty)
        for (int tx = t0.x; tx <= t1.x; ++tx)
            if (!(z >= depth_tiles[ty * u_depth_tiles.x + tx])) return false;
    return true;
}
