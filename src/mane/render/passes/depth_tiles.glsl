// The scene depth's tile map as the compute rasteriser reads it (depth_tiles.py, filled by
// depth_tiles.comp): per tile of 2^u_tile_shift x 2^u_tile_shift samples the largest window
// depth of the head's depth texture over the pixels the samples lie in. A depth z at or behind
// the max of every tile that a box of samples touches is at or behind the depth of every
// sample's pixel there, so each per-sample test `z >= depth` in the box would fail: the kernels
// skip the box's samples at once (RASTER_CULL). A tile is found by shifts (an integer
// division by a uniform costs a CPU rasteriser scalar divides in every SIMD lane).
layout(std430, binding = B_DEPTH_TILES) readonly buffer DepthTiles { float depth_tiles[]; };
uniform ivec2 u_depth_tiles;   // tiles across and down
uniform int u_tile_shift;      // log2 of a tile's side in samples
// the most tiles looked at for one box (a column spans <= 2 RASTER_MAX_SPAN + 1 samples: 17
// tiles of 8); a box touching more is not culled
#define DEPTH_TILES_MAX_TOUCHED 32

// whether z is at or behind the scene at every sample of the box q0..q1 (inclusive, in the
// sample grid); false for a NaN z
bool depth_tiles_behind(ivec2 q0, ivec2 q1, float z) {
    ivec2 t0 = q0 >> u_tile_shift;
    ivec2 t1 = min(q1 >> u_tile_shift, u_depth_tiles - 1);
    int w = u_depth_tiles.x;
    if (!(z >= depth_tiles[t0.y * w + t0.x])) return false;   // the first tile (most columns': the only one)
    if (t1 == t0) return true;
    if ((t1.x - t0.x + 1) * (t1.y - t0.y + 1) > DEPTH_TILES_MAX_TOUCHED) return false;
    for (int ty = t0.y; ty <= t1.y; ++ty)
        for (int tx = t0.x; tx <= t1.x; ++tx)
            if (!(z >= depth_tiles[ty * w + tx])) return false;
    return true;
}
