#version 430
// The scene depth's tile map (depth_tiles.py): one thread a tile of 2^u_tile_shift x
// 2^u_tile_shift samples of the rasteriser's grid (u_grid x u_grid a pixel), the largest window
// depth of the pixels its samples lie in (background: the clear's 1.0). A loop of bounded length
// a thread: no barriers or shared memory (CPU rasterisers run a work group's barriers slowly),
// the fetches free to overlap.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_DEPTH_TILES) writeonly buffer DepthTilesOut { float depth_tiles_out[]; };
uniform sampler2D u_scene_depth;   // exactly the texture the compute rasteriser tests against
uniform ivec2 u_depth_tiles;       // tiles across and down
uniform int u_tile_shift;          // log2 of a tile's side in samples
uniform int u_grid;                // samples a pixel side

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(t, u_depth_tiles))) return;
    ivec2 size = textureSize(u_scene_depth, 0);
    ivec2 p0 = (t << u_tile_shift) / u_grid;                            // the first sample's pixel
    ivec2 p1 = min((((t + 1) << u_tile_shift) - 1) / u_grid, size - 1);   // the last's, in the texture
    float m = 0.0;
    for (int y = p0.y; y <= p1.y; ++y)
        for (int x = p0.x; x <= p1.x; ++x)
            m = max(m, texelFetch(u_scene_depth, ivec2(x, y), 0).r);
    depth_tiles_out[t.y * u_depth_tiles.x + t.x] = m;
}
