#version 430
// The hair self-occlusion tile map (occlusion_tiles.py): one work group a tile of
// 2^u_tile_shift x 2^u_tile_shift samples (depth_tiles' tiles), the max over its samples of the
// depth from which a visit there is a no-op: min(the head's depth at the sample's pixel, the
// next float past the sample's nearest hair depth where its coverage has saturated, else 1.0).
// A kernel culls a column at z >= the map over every tile it touches (depth_tiles.glsl). A
// thread takes the tile's pixels in turn (at 1, 2 x 2 and 4 x 4 samples a pixel a tile is 8 x 8
// pixels: one each), reads the head's depth once and the pixel's samples in the tile (stored
// together: hair_vis.glsl), and the group's max is kept by an atomic max on the float's bits
// (non-negative floats order as their bits). Samples past the grid's edge are not looked at.
#include "hair_vis.glsl"
#define OCC_GROUP 64
layout(local_size_x = OCC_GROUP) in;
layout(std430, binding = B_DEPTH_TILES) writeonly buffer DepthTilesOut { float depth_tiles_out[]; };
uniform sampler2D u_scene_depth;   // the head's window depth per pixel (the rasteriser's)
uniform ivec2 u_depth_tiles;       // tiles across and down
uniform int u_tile_shift;          // log2 of a tile's side in samples
uniform int u_grid;                // samples a pixel side
uniform ivec2 u_raster_size;       // the sample grid
shared uint s_max;

// the depth from which a visit to sample idx (of a pixel at head depth `head`) does nothing
float no_op_from(float head, uint idx) {
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
    ivec2 t = ivec2(gl_WorkGroupID.xy);
    uint lid = gl_LocalInvocationIndex;
    if (lid == 0u) s_max = 0u;
    barrier();
    ivec2 q0 = t << u_tile_shift;
    ivec2 q1 = min(((t + 1) << u_tile_shift) - 1, u_raster_size - 1);
    ivec2 p0 = q0 / u_grid;
    ivec2 np = q1 / u_grid - p0 + 1;   // the pixels the tile's samples lie in
    int width = u_raster_size.x / u_grid;
    int g = u_grid;
    float m = 0.0;
    for (int k = int(lid); k < np.x * np.y; k += OCC_GROUP) {
        int ky = k / np.x;
        ivec2 p = p0 + ivec2(k - ky * np.x, ky);
        float head = texelFetch(u_scene_depth, p, 0).r;
        ivec2 s0 = max(q0 - p * g, ivec2(0));          // the pixel's samples in the tile
        ivec2 s1 = min(q1 - p * g, ivec2(g - 1));
        uint base = (uint(p.y) * uint(width) + uint(p.x)) * uint(g * g);
        for (int sy = s0.y; sy <= s1.y; ++sy)
            for (int sx = s0.x; sx <= s1.x; ++sx)
                m = max(m, no_op_from(head, base + uint(sy * g + sx)));
    }
    atomicMax(s_max, floatBitsToUint(m));
    barrier();
    if (lid == 0u) depth_tiles_out[t.y * u_depth_tiles.x + t.x] = uintBitsToFloat(s_max);
}
