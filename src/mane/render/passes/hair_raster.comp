#version 430
// The compute rasteriser, step 1: every segment of the expanded strands (strand_expand.comp)
// scan-converted into the sample grid (raster_segment.glsl); at each sample in front of the
// scene's depth (the head) the nearest segment is kept (hair_vis.glsl) and the coverage added;
// RASTER_HEAD_CULL: segments and columns behind the bound tile map are skipped whole: the head's
// depth (depth_tiles.py), or the head's and the saturated near hair's (occlusion_tiles.py: the
// segments split by depth between two dispatches).
// RASTER_PASS 0: depth (and the 64-bit visibility) and coverage; 1: the 32-bit path's ids.
// RASTER_BALANCE 2: the tiled form (raster_tiles.glsl, raster_tiles.py): RASTER_TILED_PHASE 1 and
// 2 bin the segments to screen tiles, 3 visits a tile's samples in shared memory (depth, id and
// coverage in one dispatch on both paths). RASTER_RESET_ID (32-bit path, RASTER_PASS 0): a visit
// that lowers a sample's depth clears its id, so that the id pass after it sets it from this
// dispatch's segments alone (the tiled form's fallback after a step that left ids).
#if RT_SUBGROUP || RASTER_SUBGROUP   // the column scans by subgroups (raster_segment.subgroup_scan)
#extension GL_KHR_shader_subgroup_arithmetic : require
#endif
#include "hair_vis.glsl"
// the tiled raster's groups hold 256 threads (raster_tiles.glsl's RT_BATCH: shared memory per thread)
#if RASTER_BALANCE == 2 && RASTER_TILED_PHASE == 3
layout(local_size_x = 256) in;
#else
layout(local_size_x = 128) in;
#endif
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
uniform sampler2D u_scene_depth;   // the head's window depth per pixel
uniform int u_points_per_strand;
uniform int u_num_segments;         // rendered strands x (points - 1)
#include "raster_view.glsl"

uint g_id;   // the visited segment (its first point; RASTER_SEGMENT sets it)
#ifndef RASTER_STATS
#define RASTER_STATS 0
#endif
#if RASTER_STATS
// statistics, off by default (HairComputePass.count_samples): per slot (work group mod 64),
// samples scanned, samples in front of the scene (RASTER_PASS 0 / VIS64), the pass-1 id atomics
// and the scanned samples skipped by the head cull
layout(std430, binding = B_RASTER_STATS) buffer RasterStats { uint raster_stats[]; };
uint g_scanned = 0u, g_written = 0u, g_id_atomics = 0u, g_culled = 0u;
#endif
#ifndef RASTER_HEAD_CULL
#define RASTER_HEAD_CULL 0
#endif
#if RASTER_HEAD_CULL
// segments and sample columns at or behind the head's depth tile map (depth_tiles.py): each of
// their samples would fail visit()'s `z >= scene depth`, so none is visited
#include "depth_tiles.glsl"
#define RASTER_CULL(Q0, Q1, Z) depth_tiles_behind(Q0, Q1, Z)
#if RASTER_STATS
#define RASTER_CULLED(N) { g_scanned += uint(N); g_culled += uint(N); }
#endif
#endif

void visit(ivec2 q, float z, float cov) {
#if RASTER_STATS
    g_scanned++;
#endif
    if (!(z >= 0.0 && z < 1.0)) return;
    if (z >= texelFetch(u_scene_depth, q / u_grid, 0).r) return;
#if RASTER_STATS
    g_written++;
#endif
    uint idx = sample_index(q, u_raster_size.x / u_grid, u_grid);
    uint zb = floatBitsToUint(z);
    // Read before the atomics, which run at the L2's atomic rate (docs/performance.md): a
    // sample's nearest depth only falls and its coverage only grows during the dispatch, so a
    // value read here (perhaps stale) that already beats this segment's makes the atomic a
    // no-op; and coverage past COVER_SATURATED (alpha 1 - e^-12) is not worth adding to.
#if VIS64
    uint64_t key = (uint64_t(zb) << 32) | uint64_t(g_id);
    if (key < vis[idx]) atomicMin(vis[idx], key);
    if (cover[idx] < COVER_SATURATED) atomicAdd(cover[idx], cover_units(cov));
#elif RASTER_PASS == 0
#ifdef RASTER_RESET_ID
    if (zb < vis_depth[idx] && atomicMin(vis_depth[idx], zb) > zb) vis_id[idx] = 0u;
#else
    if (zb < vis_depth[idx]) atomicMin(vis_depth[idx], zb);
#endif
    if (cover[idx] < COVER_SATURATED) atomicAdd(cover[idx], cover_units(cov));
#else
    if (vis_depth[idx] == zb) {
        atomicMax(vis_id[idx], g_id + 1u);   // 0: none
#if RASTER_STATS
        g_id_atomics++;
#endif
    }
#endif
}
// The depth split (occlusion_tiles.py): u_split_side 0, every segment; 1, those with an end in
// front of u_split_depth; 2, the others (the same expression in one program: each segment in
// exactly one of the two dispatches, NaN depths in the second).
uniform float u_split_depth;
uniform int u_split_side;
#define RASTER_KEEP_SPAN(S) (u_split_side == 0 || ((S.za < u_split_depth || S.zb < u_split_depth) == (u_split_side == 1)))
#define RASTER_VISIT(Q, Z, COV) visit(Q, Z, COV)
#define RASTER_SEGMENT(I) g_id = uint(I)
#include "raster_segment.glsl"
#if RASTER_BALANCE == 2
#include "raster_tiles.glsl"
#endif

void main() {
#if RASTER_BALANCE == 2
    raster_tiled_main();
#if RASTER_STATS && RASTER_TILED_PHASE == 2
    return;   // counted by phases 1 (segment culls) and 3 (visits)
#endif
#else
    raster_expanded_segment();   // every invocation (the balanced form shares the group's columns)
#endif
#if RASTER_STATS
    uint slot = (gl_WorkGroupID.x & 63u) * 4u;
#if VIS64 || RASTER_PASS == 0
    atomicAdd(raster_stats[slot], g_scanned);
    atomicAdd(raster_stats[slot + 1u], g_written);
    atomicAdd(raster_stats[slot + 3u], g_culled);
#endif
#if !VIS64 && (RASTER_PASS == 1 || RASTER_BALANCE == 2)
    atomicAdd(raster_stats[slot + 2u], g_id_atomics);   // the tiled form: its walk 2's, in shared memory
#endif
#endif
}
