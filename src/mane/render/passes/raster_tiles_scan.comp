#version 430
// The tiled scan conversion's list layout (raster_tiles.py, between the bin's count and scatter
// phases of hair_raster.comp; raster_tiles.glsl): the per-tile counts become exclusive offsets
// (saturating at RT_LIMIT, past every capacity), the scatter's cursors, the list of non-empty
// tiles and the two indirect dispatches: the tiled raster over the non-empty tiles, or, when the
// entries pass the capacity, none of it and the balanced form's dispatch over every segment
// instead (the frame's step stays exact). The counts are zeroed for the next step.
// Three dispatches (SCAN_PHASE), a block being SCAN_BLOCK consecutive tiles, PER to a thread:
//   1. a work group a block: the block's (entries, non-empty tiles) sums;
//   2. one work group: the blocks' sums scanned into each block's exclusive offsets (a thread a
//      run of consecutive blocks, bounded: blocks / GROUP + 1), the total, the dispatches;
//   3. a work group a block: its tiles' offsets, cursors and list places from its offset.
// (One work group over every tile, a thread a run of them, read the counts in serial runs:
// 0.13-0.14 ms a step on an H200 at 1080p with 4 samples.)
// the index buffer's layout (RT_TILED_ARGS ... RT_HEADER): raster_tiles.py's defines
#define RT_LIMIT 0x40000000u
#define GROUP 256
#define BLOCK SCAN_BLOCK               // raster_tiles.py's
#define PER (BLOCK / GROUP)
layout(local_size_x = GROUP) in;
// counts (tiles), cursors (tiles), then the blocks' (entries, non-empty) sums / offsets
layout(std430, binding = B_TILE_COUNTS) buffer TileCounts { uint rt_counts[]; };
layout(std430, binding = B_TILE_INDEX) buffer TileIndex { uint rt_index[]; };
uniform ivec2 u_rt_tiles;       // tiles across and down
uniform uint u_rt_capacity;     // entries the list storage holds (< RT_LIMIT)
uniform ivec2 u_rt_fallback;    // the balanced form's work groups over every segment
shared uvec2 sc[2 * GROUP];     // (entries, non-empty tiles) inclusive scan, two halves in turn

uint sat_add(uint a, uint b) {   // a, b <= RT_LIMIT
    return min(a + b, RT_LIMIT);
}

uvec2 sat_add2(uvec2 a, uvec2 b) {
    return uvec2(sat_add(a.x, b.x), a.y + b.y);
}

// the work group's exclusive scan of v (every thread; barriers inside), the group's total in all_
uvec2 group_scan(uvec2 v, out uvec2 all_) {
    int lid = int(gl_LocalInvocationID.x);
    sc[lid] = v;
    barrier();
    int src = 0;
    for (int off = 1; off < GROUP; off <<= 1) {
        uvec2 x = sc[src + lid];
        if (lid >= off) x = sat_add2(x, sc[src + lid - off]);
        src = GROUP - src;
        sc[src + lid] = x;
        barrier();
    }
    all_ = sc[src + GROUP - 1];
    return lid > 0 ? sc[src + lid - 1] : uvec2(0u);
}

void main() {
    int lid = int(gl_LocalInvocationID.x);
    int n = u_rt_tiles.x * u_rt_tiles.y;
    int blocks = (n + BLOCK - 1) / BLOCK;
    int sums = 2 * n;   // the blocks' pairs in rt_counts
#if SCAN_PHASE == 1 || SCAN_PHASE == 3
    int g = int(gl_WorkGroupID.x);
    int t0 = g * BLOCK + lid * PER;
    uint c[PER];
    uvec2 own = uvec2(0u);
    for (int k = 0; k < PER; ++k) {
        int t = t0 + k;
        c[k] = t < n ? min(rt_counts[t], RT_LIMIT) : 0u;
        own = uvec2(sat_add(own.x, c[k]), own.y + uint(c[k] > 0u));
    }
    uvec2 all_;
    uvec2 excl = group_scan(own, all_);
#if SCAN_PHASE == 1
    if (lid == 0) {
        rt_counts[sums + 2 * g] = all_.x;
        rt_counts[sums + 2 * g + 1] = all_.y;
    }
#else
    uvec2 before = sat_add2(uvec2(rt_counts[sums + 2 * g], rt_counts[sums + 2 * g + 1]), excl);
    uint o = before.x, m = before.y;
    for (int k = 0; k < PER; ++k) {
        int t = t0 + k;
        if (t >= n) break;
        rt_index[RT_HEADER + t] = o;
        rt_counts[n + t] = o;   // the scatter's cursor
        rt_counts[t] = 0u;
        if (c[k] > 0u) rt_index[RT_HEADER + n + 1 + int(m++)] = uint(t);
        o = sat_add(o, c[k]);
    }
#endif
#else   // SCAN_PHASE 2: one work group over the blocks' sums, each replaced by its offset
    int chunk = (blocks + GROUP - 1) / GROUP;
    int b0 = min(lid * chunk, blocks), b1 = min(b0 + chunk, blocks);
    uvec2 own = uvec2(0u);
    for (int b = b0; b < b1; ++b) own = sat_add2(own, uvec2(rt_counts[sums + 2 * b], rt_counts[sums + 2 * b + 1]));
    uvec2 all_;
    uvec2 o = group_scan(own, all_);
    for (int b = b0; b < b1; ++b) {
        uvec2 v = uvec2(rt_counts[sums + 2 * b], rt_counts[sums + 2 * b + 1]);
        rt_counts[sums + 2 * b] = o.x;
        rt_counts[sums + 2 * b + 1] = o.y;
        o = sat_add2(o, v);
    }
    bool overflow = all_.x > u_rt_capacity;
    if (lid == 0) {
        rt_index[RT_HEADER + n] = all_.x;
        rt_index[RT_TILED_ARGS] = overflow ? 0u : all_.y;
        rt_index[RT_TILED_ARGS + 1] = 1u;
        rt_index[RT_TILED_ARGS + 2] = 1u;
        rt_index[RT_FALLBACK_ARGS] = overflow ? uint(u_rt_fallback.x) : 0u;
        rt_index[RT_FALLBACK_ARGS + 1] = overflow ? uint(u_rt_fallback.y) : 1u;
        rt_index[RT_FALLBACK_ARGS + 2] = 1u;
        rt_index[RT_OVERFLOW] = overflow ? 1u : 0u;
        rt_index[RT_TOTAL] = all_.x;
        rt_index[RT_PEAK] = max(rt_index[RT_PEAK], all_.x);
    }
#endif
}
