#version 430
// The hair self-occlusion tile map (occlusion_tiles.py): one thread a tile of 2^u_tile_shift x
// 2^u_tile_shift samples (depth_tiles' tiles), the max over its samples of the depth from which
// a visit there is a no-op: min(the head's depth at the sample's pixel, the next float past the
// sample's nearest hair depth where its coverage has saturated, else 1.0). A kernel culls a
// column at z >= the map over every tile it touches (depth_tiles.glsl). Samples past the grid's
// edge are not looked at; a loop of bounded length a thread, no barriers (CPU rasterisers).
#include "hair_vis.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_DEPTH_TILES) writeonly buffer DepthTilesOut { float depth_tiles_out[]; };
uniform sampler2D u_scene_depth;   // the head's window depth per pixel (the rasteriser's)
uniform ivec2 u_depth_tiles;       // tiles across and down
uniform int u_tile_shift;          // log2 of a tile's side in samples
uniform int u_grid;                // samples a pixel side
uniform ivec2 u_raster_size;       // the sample grid

// the depth from which a visit to sample q (index idx) does nothing
float no_op_from(ivec2 q, uint idx) {
    float head = texelFetch(u_scene_depth, q / u_grid, 0).r;
    if (cover[idx] < COVER_SATURATED) return head;
#if VIS64
    uint zb = uint(vis[idx] >> 32);
#else
    uint zb = vis_depth[idx];
#endif
    // a depth in [FLT_MIN, 1): the next float is strictly further (z >= it <=> z > depth); else
    // (none, a denormal, a negative zero) no hair cull
    if (zb < 0x00800000u || zb >= 0x3F800000u) return head;
    return min(head, uintBitsToFloat(zb + 1u));
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(t, u_depth_tiles))) return;
    ivec2 q0 = t << u_tile_shift;
    ivec2 q1 = min(((t + 1) << u_tile_shift) - 1, u_raster_size - 1);
    int width = u_raster_size.x / u_grid;
    float m = 0.0;
    for (int y = q0.y; y <= q1.y; ++y)
        for (int x = q0.x; x <= q1.x; ++x) {
            ivec2 q = ivec2(x, y);
            m = max(m, no_op_from(q, sample_index(q, width, u_grid)));
        }
    depth_tiles_out[t.y * u_depth_tiles.x + t.x] = m;
}
