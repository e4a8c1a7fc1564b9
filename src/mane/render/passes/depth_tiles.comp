#version 430
// The scene depth's tile map (depth_tiles.py): one work group per DEPTH_TILE x DEPTH_TILE tile
// of pixels, one thread a pixel; the tile's largest window depth (background: the clear's 1.0),
// pixels past the texture's edge left out. Window depths are >= 0, so their bits order as the
// floats do and a shared atomicMax on the bits is the float max.
layout(local_size_x = DEPTH_TILE, local_size_y = DEPTH_TILE) in;
layout(std430, binding = B_DEPTH_TILES) writeonly buffer DepthTilesOut { uint depth_tiles_out[]; };
uniform sampler2D u_scene_depth;   // exactly the texture the compute rasteriser tests against
uniform ivec2 u_depth_tiles;       // tiles across and down

shared uint tile_max;

void main() {
    if (gl_LocalInvocationIndex == 0u) tile_max = 0u;
    barrier();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (all(lessThan(p, textureSize(u_scene_depth, 0))))
        atomicMax(tile_max, floatBitsToUint(max(texelFetch(u_scene_depth, p, 0).r, 0.0)));
    barrier();
    if (gl_LocalInvocationIndex == 0u)
        depth_tiles_out[gl_WorkGroupID.y * uint(u_depth_tiles.x) + gl_WorkGroupID.x] = tile_max;
}
