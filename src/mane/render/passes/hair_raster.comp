#version 430
// The compute rasteriser, step 1: every segment of the expanded strands (strand_expand.comp)
// scan-converted into the sample grid (raster_segment.glsl); at each sample in front of the
// scene's depth (the head) the nearest segment is kept (hair_vis.glsl) and the coverage added.
// RASTER_PASS 0: depth (and the 64-bit visibility) and coverage; 1: the 32-bit path's ids.
#include "hair_vis.glsl"
layout(local_size_x = 128) in;
layout(std430, binding = 3) readonly buffer Expanded { vec4 expanded[]; };
uniform sampler2D u_scene_depth;   // the head's window depth per pixel
uniform int u_points_per_strand;
uniform int u_num_segments;         // rendered strands x (points - 1)
#include "raster_view.glsl"

uint g_id;

void visit(ivec2 q, float z, float cov) {
    if (!(z >= 0.0 && z < 1.0)) return;
    if (z >= texelFetch(u_scene_depth, q / u_grid, 0).r) return;
    uint idx = sample_index(q, u_raster_size.x / u_grid, u_grid);
    uint zb = floatBitsToUint(z);
#if VIS64
    atomicMin(vis[idx], (uint64_t(zb) << 32) | uint64_t(g_id));
    atomicAdd(cover[idx], cover_units(cov));
#elif RASTER_PASS == 0
    atomicMin(vis_depth[idx], zb);
    atomicAdd(cover[idx], cover_units(cov));
#else
    if (vis_depth[idx] == zb) atomicMax(vis_id[idx], g_id + 1u);   // 0: none
#endif
}
#define RASTER_VISIT(Q, Z, COV) visit(Q, Z, COV)
#include "raster_segment.glsl"

void main() {
    int k = int((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
                + gl_LocalInvocationID.x);
    if (k >= u_num_segments) return;
    int per = u_points_per_strand - 1;
    int strand = k / per;
    int i = strand * u_points_per_strand + (k - strand * per);   // the segment's first point
    vec4 p0 = expanded[2 * i];
    vec4 p1 = expanded[2 * i + 2];
    RasterPoint a = raster_point(p0.xyz, p0.w);
    RasterPoint b = raster_point(p1.xyz, p1.w);
    if (!a.ok || !b.ok) return;   // behind the eye
    g_id = uint(i);
    raster_segment(a.s, b.s, a.window_z, b.window_z, a.half_width, b.half_width, a.coverage, b.coverage,
                   u_raster_size);
}
