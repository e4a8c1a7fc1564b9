#version 430
// The tiled scan conversion's list layout (raster_tiles.py, between the bin's count and scatter
// phases of hair_raster.comp; raster_tiles.glsl): one work group over every tile. The per-tile
// counts become exclusive offsets (saturating at RT_LIMIT, past every capacity), the scatter's
// cursors, the list of non-empty tiles and the two indirect dispatches: the tiled raster over
// the non-empty tiles, or, when the entries pass the capacity, none of it and the balanced
// form's dispatch over every segment instead (the frame's step stays exact). The counts are
// zeroed for the next step. A thread takes a run of consecutive tiles (bounded: tiles / 256 + 1).
// the index buffer's layout (RT_TILED_ARGS ... RT_HEADER): raster_tiles.py's defines
#define RT_LIMIT 0x40000000u
#define GROUP 256
layout(local_size_x = GROUP) in;
layout(std430, binding = B_TILE_COUNTS) buffer TileCounts { uint rt_counts[]; };   // counts, then cursors
layout(std430, binding = B_TILE_INDEX) buffer TileIndex { uint rt_index[]; };
uniform ivec2 u_rt_tiles;       // tiles across and down
uniform uint u_rt_capacity;     // entries the list storage holds (< RT_LIMIT)
uniform ivec2 u_rt_fallback;    // the balanced form's work groups over every segment
shared uvec2 sc[2 * GROUP];     // (entries, non-empty tiles) inclusive scan, two halves in turn

uint sat_add(uint a, uint b) {   // a, b <= RT_LIMIT
    return min(a + b, RT_LIMIT);
}

void main() {
    int lid = int(gl_LocalInvocationID.x);
    int n = u_rt_tiles.x * u_rt_tiles.y;
    int chunk = (n + GROUP - 1) / GROUP;
    int t0 = min(lid * chunk, n), t1 = min(t0 + chunk, n);
    uvec2 own = uvec2(0u);
    for (int t = t0; t < t1; ++t) {
        uint c = min(rt_counts[t], RT_LIMIT);
        own = uvec2(sat_add(own.x, c), own.y + uint(c > 0u));
    }
    sc[lid] = own;
    barrier();
    int src = 0;
    for (int off = 1; off < GROUP; off <<= 1) {
        uvec2 v = sc[src + lid];
        if (lid >= off) {
            uvec2 w = sc[src + lid - off];
            v = uvec2(sat_add(v.x, w.x), v.y + w.y);
        }
        src = GROUP - src;
        sc[src + lid] = v;
        barrier();
    }
    uvec2 before = lid > 0 ? sc[src + lid - 1] : uvec2(0u);
    uvec2 all_ = sc[src + GROUP - 1];
    bool overflow = all_.x > u_rt_capacity;
    uint o = before.x, m = before.y;
    for (int t = t0; t < t1; ++t) {
        uint c = min(rt_counts[t], RT_LIMIT);
        rt_index[RT_HEADER + t] = o;
        rt_counts[n + t] = o;   // the scatter's cursor
        rt_counts[t] = 0u;
        if (c > 0u) rt_index[RT_HEADER + n + 1 + int(m++)] = uint(t);
        o = sat_add(o, c);
    }
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
}
