// The tiled scan conversion of hair_raster.comp (RASTER_BALANCE 2; raster_tiles.py drives it):
// the segments binned to the screen tiles of RT_SIDE x RT_SIDE samples they touch, then one work
// group a tile visits its segments' samples in shared memory (a tile's depth, id, coverage and
// head depth loaded once, written back once), where a close-up's ~100 visits per covered sample
// would otherwise each read global memory. Included by hair_raster.comp after
// raster_segment.glsl (raster_thread_span, raster_span, raster_column_range: the same set-up and
// the same column ranges, depths and coverages as the other two forms), with visit()'s rules.
//
// RASTER_TILED_PHASE 1 (count) and 2 (scatter): a thread a segment (its span as the other forms
// set it up: the depth split and the segment cull against the bound tile map), the tiles its
// columns can touch (rt_bin_walk: per strip of RT_SIDE columns, the rows a sample's margin
// around the centre line at the strip's edge columns widened by the larger half width: a
// superset of the tiles of its samples, never fewer). Counts and ranks go through a work
// group's shared table of RT_SLOTS tiles (a close-up's consecutive segments share tiles; a far
// head's segments all hit a few: one global atomic per table slot instead of per segment), a
// tile that finds no slot in RT_PROBES probes going to the global counter itself. The scatter
// keeps the slot and the rank its count's shared atomic returned for a thread's first RT_KEEP
// tiles, and writes those entries at the slot's base + rank once the group has reserved its
// slots' ranges: no second walk of the span and no second atomic (H200, the 100k close-up's
// raster 2.08 -> 2.06 ms, the 1M close-up's 6.89 -> 6.81); a thread's further tiles take a
// global cursor's slot at once.
// raster_tiles_scan.comp then turns the counts into list offsets, the cursors the scatter fills
// the lists with (entries: the segment's first point), the list of non-empty tiles and the
// indirect dispatches; past the entries' capacity the frame's step runs the balanced form
// instead (its indirect dispatch gets the work groups, the tiled raster none).
// RASTER_TILED_PHASE 3 (raster): a work group a non-empty tile. Walk 1 takes the tile's entries
// RT_BATCH at a time: a thread each sets up one (the same raster_span), clips its columns to the
// tile; the batch's columns are prefix-summed and dealt to the threads (as the balanced form),
// each column's samples (raster_column_range, clipped to the tile's rows) visited with
// visit()'s depth-min and coverage-add rules on shared words. Walk 2 visits them again for the
// id: among the segments at a sample's final depth the largest id + 1 (32-bit path: as its id
// pass) or the smallest id (VIS64: what the 64-bit atomic min of (depth << 32 | id) keeps), so
// that both paths leave what their other forms leave, with no 64-bit shared atomics; a sample
// whose depth this step lowered forgets the id an earlier step (the depth split) left.
// RT_PACKED (VIS64 with raster_tiles.PACKED): the tile's words are VIS64's own (depth << 32 | id),
// and walk 1 takes their 64-bit atomic min in shared memory (GL_NV_shader_atomic_int64 has
// shared atomics): the id comes with the depth, and walk 2 and the id reset are not run; a
// visit at a saturated sample's own depth may still lower its id, so the cull starts one
// depth step past it.
// Culls: per 8 x 8 samples of the tile (RT_SUB), refreshed after every batch, the least 32-bit
// depth from which a visit is a no-op there: min(the head's depth, 1.0, the sample's depth where
// its coverage has saturated), max over the block's samples. A column with 0 < z at or past it
// over the blocks it touches, or an entry whose least depth (raster_span_box's margin) is at or
// past the tile's, is skipped: each of its visits would fail the head or range test or lose the
// depth min (a tie too: the id is walk 2's) and skip the saturated coverage add; the words only
// fall (depth) and rise (coverage) during the walk, so a block's value stays a valid bound. Walk
// 2 skips a column whose depth bits pass every sample's final depth bits in its blocks (it
// cannot equal any). Every loop is bounded: strips <= (RASTER_MAX_STEPS + 1) / RT_SIDE + 2, rows
// <= the grid, a tile's entries <= the capacity, a batch's columns <= RT_BATCH x RT_SIDE.
// RT_SHIFT (log2 of a tile's side in samples) and the index buffer's layout (RT_TILED_ARGS,
// RT_FALLBACK_ARGS, RT_OVERFLOW, RT_TOTAL, RT_PEAK, RT_HEADER) come from raster_tiles.py
#define RT_SIDE (1 << RT_SHIFT)
#define RT_PACKED (VIS64 && RT_PACKED_OK)
#define RT_AREA (RT_SIDE * RT_SIDE)
// phase 3's threads a group (hair_raster.comp: 256, the others 128)
#define RT_GROUP int(gl_WorkGroupSize.x)
// a walk's entries a batch (<= RT_GROUP). A work group's shared memory is what bounds how many
// share an SM (H200, the 100k close-up: 4 KB more per group took the raster 2.97 -> 3.94 ms):
// with 128 threads a batch of 64 took the raster 2.49 -> 2.16 ms against 128 (32: 2.26, more
// batches, and the 1M close-up 7.2 -> 8.1 ms); 256 threads a group with a batch of 128 hold
// twice the threads in the same shared memory (2.16 -> 2.08 ms; the 1M close-up 7.18 -> 6.89;
// a batch of 64 at 256 threads: 2.75, 9.51)
#define RT_BATCH 128
#define RT_SUB_SHIFT 3                          // the cull blocks: 8 x 8 samples, 4 x 4 a tile
#define RT_SUBS ((RT_SIDE >> RT_SUB_SHIFT) * (RT_SIDE >> RT_SUB_SHIFT))
#define RT_SLOTS 256                            // the bin's shared table (a power of two)
#define RT_PROBES 4
#define RT_EMPTY 0xFFFFFFFFu
// the index buffer: the two indirect dispatches, the overflow flag, the entries' total, the
// largest total seen; from RT_HEADER the tiles' offsets (tiles + 1), then the non-empty tiles
layout(std430, binding = B_TILE_INDEX) buffer TileIndex { uint rt_index[]; };   // offsets at RT_HEADER
layout(std430, binding = B_TILE_ENTRIES) buffer TileEntries { uint rt_entries[]; };
uniform ivec2 u_rt_tiles;   // tiles across and down
uniform uint u_rt_capacity; // entries the list storage holds

#if RASTER_TILED_PHASE == 1 || RASTER_TILED_PHASE == 2
layout(std430, binding = B_TILE_COUNTS) buffer TileCounts { uint rt_counts[]; };   // counts, then cursors
shared uint rt_key[RT_SLOTS];
shared uint rt_n[RT_SLOTS];
shared uint rt_base[RT_SLOTS];

// the minor-axis samples lo..hi (swapped as s; clamped to the grid; hi < lo: none) holding every
// sample of span s's columns cx0..cx1: the centre line's rows at the two edge columns (the same
// expression as raster_column_range's), the larger half width and a sample's margin (float
// rounding of a column's y, as raster_span_box); the whole grid's rows when an end lies past
// 2^20 samples or a value is NaN
void rt_strip_rows(RasterSpan s, int cx0, int cx1, int ny, out int lo, out int hi) {
    vec2 b = s.a + s.d;
    float h = min(max(s.ha, s.hb) * s.inv_cos, float(RASTER_MAX_SPAN));
    float ya = s.a.y + (float(cx0) + 0.5 - s.a.x) / s.d.x * s.d.y;
    float yb = s.a.y + (float(cx1) + 0.5 - s.a.x) / s.d.x * s.d.y;
    float flo = min(ya, yb) - h - 1.5, fhi = max(ya, yb) + h + 0.5;
    lo = 0;
    hi = ny - 1;
    if (!(s.ha == s.ha && s.hb == s.hb && flo <= fhi && h <= float(RASTER_MAX_SPAN))
        || !(max(max(abs(s.a.x), abs(s.a.y)), max(abs(b.x), abs(b.y))) <= 1048576.0)) return;
    lo = int(clamp(floor(flo), 0.0, float(ny)));
    hi = int(clamp(ceil(fhi), -1.0, float(ny - 1)));
}

// the shared table's slot of tile t: claimed when free (claim), else found; -1: none there
int rt_slot(uint t, bool claim) {
    uint h = (t * 2654435761u) >> 24;   // RT_SLOTS = 256
    for (int p = 0; p < RT_PROBES; ++p) {
        uint j = (h + uint(p)) & uint(RT_SLOTS - 1);
        uint prev = claim ? atomicCompSwap(rt_key[j], RT_EMPTY, t) : rt_key[j];
        if (prev == t || (claim && prev == RT_EMPTY)) return int(j);
    }
    return -1;
}

// the scatter's kept tiles a thread: (slot | rank << 8)
#define RT_KEEP 8
uint rt_kept[RT_KEEP];
int rt_n_kept = 0;

// every tile span s may touch: phase 1 counts it (the shared table's or the global count);
// phase 2 counts it in the shared table and keeps its slot and rank (the first RT_KEEP), or
// takes a global cursor's slot and writes the entry at once
void rt_bin_walk(RasterSpan s, uint entry) {
    int ny = s.steep ? u_raster_size.x : u_raster_size.y;
    int n = u_rt_tiles.x * u_rt_tiles.y;
    for (int sx = s.x0 >> RT_SHIFT; sx <= (s.x1 >> RT_SHIFT); ++sx) {
        int lo, hi;
        rt_strip_rows(s, max(s.x0, sx << RT_SHIFT), min(s.x1, (sx << RT_SHIFT) + RT_SIDE - 1), ny, lo, hi);
        if (hi < lo) continue;
        for (int sy = lo >> RT_SHIFT; sy <= (hi >> RT_SHIFT); ++sy) {
            ivec2 t2 = s.steep ? ivec2(sy, sx) : ivec2(sx, sy);
            uint t = uint(t2.y * u_rt_tiles.x + t2.x);
#if RASTER_TILED_PHASE == 1
            int j = rt_slot(t, true);
            if (j >= 0) atomicAdd(rt_n[j], 1u);
            else atomicAdd(rt_counts[t], 1u);
#else
            int j = rt_n_kept < RT_KEEP ? rt_slot(t, true) : -1;
            if (j >= 0) {
                rt_kept[rt_n_kept] = uint(j) | (atomicAdd(rt_n[j], 1u) << 8);
                ++rt_n_kept;
            } else {
                uint pos = atomicAdd(rt_counts[n + int(t)], 1u);
                if (pos < u_rt_capacity) rt_entries[pos] = entry;
            }
#endif
        }
    }
}

void raster_tiled_main() {
#if RASTER_TILED_PHASE == 2
    if (rt_index[RT_OVERFLOW] != 0u) return;   // the step runs the balanced form (uniform)
#endif
    uint lid = gl_LocalInvocationID.x;
    for (uint j = lid; j < uint(RT_SLOTS); j += gl_WorkGroupSize.x) {
        rt_key[j] = RT_EMPTY;
        rt_n[j] = 0u;
    }
    barrier();
    RasterSpan s;
    int i;
    bool any = raster_thread_span(s, i);
    if (any) rt_bin_walk(s, uint(i));
    barrier();
    int n = u_rt_tiles.x * u_rt_tiles.y;
    for (uint j = lid; j < uint(RT_SLOTS); j += gl_WorkGroupSize.x) {
        uint t = rt_key[j];
        if (t == RT_EMPTY || rt_n[j] == 0u) continue;
#if RASTER_TILED_PHASE == 1
        atomicAdd(rt_counts[t], rt_n[j]);
#else
        rt_base[j] = atomicAdd(rt_counts[n + int(t)], rt_n[j]);
#endif
    }
#if RASTER_TILED_PHASE == 2
    barrier();
    for (int k = 0; k < rt_n_kept; ++k) {
        uint pos = rt_base[rt_kept[k] & 0xFFu] + (rt_kept[k] >> 8);
        if (pos < u_rt_capacity) rt_entries[pos] = uint(i);
    }
#endif
}

#elif RASTER_TILED_PHASE == 3
#if RT_PACKED
shared uint64_t rt_vis[RT_AREA];  // VIS64's words
#define RT_DEPTH(LI) uint(rt_vis[LI] >> 32)
#else
shared uint rt_depth[RT_AREA];   // depth bits (hair_vis.glsl's, or VIS64's high word)
shared uint rt_id[RT_AREA];      // 32-bit path: id + 1 (0: none); VIS64: the id (RT_EMPTY: none)
#define RT_DEPTH(LI) rt_depth[LI]
#endif
shared uint rt_cover[RT_AREA];
shared uint rt_head[RT_AREA];    // the head's window depth bits at the sample's pixel
shared uint rt_sub[RT_SUBS];     // the cull blocks' bounds (walk 1: float bits; walk 2: depth bits)
shared vec4 rt_ad[RT_BATCH];     // a batch's spans: a, d
shared vec4 rt_zh[RT_BATCH];     // za, zb, ha, hb
shared uvec4 rt_ci[RT_BATCH];    // raster_span_ci: ca, cb, inv_cos, first point
shared int rt_xs[RT_BATCH];      // raster_span_xs: the first column in the tile, steep
#if RT_SUBGROUP
// the batch's columns scanned by subgroups (GL_KHR_shader_subgroup_arithmetic, subgroups of
// consecutive invocations of >= RT_MIN_SUBGROUP: raster_tiles.subgroup_scan), then each
// subgroup's total in front: two barriers where the Hillis-Steele scan takes log2(RT_BATCH) + 1
#define RT_MIN_SUBGROUP 8
shared int rt_scan[RT_BATCH];
shared int rt_wsum[RT_BATCH / RT_MIN_SUBGROUP];
#else
shared int rt_scan[2 * RT_BATCH];
#endif

// walk 1's bound at a sample: visits at 0 < z with bits at or past it are no-ops
uint rt_no_op_from(int li) {
    uint m = min(rt_head[li], 0x3F800000u);
#if RT_PACKED
    uint d = RT_DEPTH(li);   // a visit at d may still lower the id
    return rt_cover[li] >= COVER_SATURATED && d < m ? d + 1u : m;
#else
    return rt_cover[li] >= COVER_SATURATED ? min(m, rt_depth[li]) : m;
#endif
}

// the blocks' bounds from the tile's words now (every thread; barriers inside)
void rt_refresh(int walk) {
    int lid = int(gl_LocalInvocationID.x);
    barrier();   // the last batch's visits done
    if (lid < RT_SUBS) rt_sub[lid] = 0u;
    barrier();
    // RT_GROUP / RT_SUBS threads a block, a row of 8 samples each
    int per = RT_GROUP / RT_SUBS;
    int b = lid / per, r = lid - b * per;
    int bs = RT_SIDE >> RT_SUB_SHIFT;
    ivec2 o = ivec2(b % bs, b / bs) << RT_SUB_SHIFT;
    uint m = 0u;
    for (int y = r; y < (1 << RT_SUB_SHIFT); y += per)
        for (int x = 0; x < (1 << RT_SUB_SHIFT); ++x) {
            int li = (o.y + y) * RT_SIDE + o.x + x;
            uint d = RT_DEPTH(li);
            m = max(m, walk == 1 ? rt_no_op_from(li) : (d == VIS_EMPTY ? 0u : d));
        }
    atomicMax(rt_sub[b], m);
    barrier();
}

// the largest block bound over local samples l0..l1 (inclusive, in the tile)
uint rt_bound(ivec2 l0, ivec2 l1) {
    ivec2 b0 = l0 >> RT_SUB_SHIFT, b1 = l1 >> RT_SUB_SHIFT;
    int bs = RT_SIDE >> RT_SUB_SHIFT;
    uint m = 0u;
    for (int by = b0.y; by <= b1.y; ++by)
        for (int bx = b0.x; bx <= b1.x; ++bx) m = max(m, rt_sub[by * bs + bx]);
    return m;
}

void rt_visit(int walk, int li, float z, float cov, uint id) {
#if RASTER_STATS
    if (walk == 1) g_scanned++;
#endif
    if (!(z >= 0.0 && z < 1.0)) return;
    if (z >= uintBitsToFloat(rt_head[li])) return;
    uint zb = floatBitsToUint(z);
    if (walk == 1) {
#if RASTER_STATS
        g_written++;
#endif
#if RT_PACKED
        if (zb <= RT_DEPTH(li)) atomicMin(rt_vis[li], (uint64_t(zb) << 32) | uint64_t(id));
#else
        if (zb < rt_depth[li]) atomicMin(rt_depth[li], zb);
#endif
        if (rt_cover[li] < COVER_SATURATED) atomicAdd(rt_cover[li], cover_units(cov));
    } else if (RT_DEPTH(li) == zb) {
#if RT_PACKED
        // (walk 2 is not run)
#elif VIS64
        atomicMin(rt_id[li], id);
#else
        atomicMax(rt_id[li], id + 1u);
#endif
#if RASTER_STATS
        g_id_atomics++;
#endif
    }
}

// one walk over the tile's entries begin..end-1; t0: the tile's first sample
void rt_walk(int walk, int begin, int end, ivec2 t0) {
    int lid = int(gl_LocalInvocationID.x);
    for (int base = begin; base < end; base += RT_BATCH) {
        rt_refresh(walk);
        uint tile_bound = rt_bound(ivec2(0), ivec2(RT_SIDE - 1));
        RasterSpan s;
        s.x0 = 0;
        s.x1 = -1;
        int i = 0, cx0 = 0, cols = 0;
        if (lid < RT_BATCH && base + lid < end) {
            i = int(rt_entries[base + lid]);
            vec4 p0 = expanded[2 * i];
            vec4 p1 = expanded[2 * i + 2];
            RasterPoint a = raster_point(p0.xyz, p0.w);
            RasterPoint b = raster_point(p1.xyz, p1.w);
            s = raster_span(a.s, b.s, a.window_z, b.window_z, a.half_width, b.half_width, a.coverage, b.coverage,
                            u_raster_size);
            int m0 = s.steep ? t0.y : t0.x;   // the tile's columns along the major axis
            cx0 = max(s.x0, m0);
            cols = max(min(s.x1, m0 + RT_SIDE - 1) - cx0 + 1, 0);
            float zmin = min(s.za, s.zb) - 1e-6 * (1.0 + abs(s.za) + abs(s.zb));
            bool culled = walk == 1 ? (zmin > 0.0 && floatBitsToUint(zmin) >= tile_bound)
                                    : (zmin > 0.0 && floatBitsToUint(zmin) > tile_bound);
            if (cols > 0 && culled) {
#if RASTER_STATS
                if (walk == 1) {
                    int n0 = s.steep ? t0.x : t0.y;
                    for (int x = cx0; x < cx0 + cols; ++x) {
                        int y0, y1;
                        float z, cov;
                        raster_column_range(s, x, u_raster_size, y0, y1, z, cov);
                        int c = max(min(y1, n0 + RT_SIDE - 1) - max(y0, n0) + 1, 0);
                        g_scanned += uint(c);
                        g_culled += uint(c);
                    }
                }
#endif
                cols = 0;
            }
        }
        if (lid < RT_BATCH) {
            rt_ad[lid] = vec4(s.a, s.d);
            rt_zh[lid] = vec4(s.za, s.zb, s.ha, s.hb);
            rt_ci[lid] = raster_span_ci(s, i);
            rt_xs[lid] = raster_span_xs(s, cx0);
#if !RT_SUBGROUP
            rt_scan[lid] = cols;
#endif
        }
#if RT_SUBGROUP
        int incl = subgroupInclusiveAdd(cols);   // (0 past the batch)
        if (lid < RT_BATCH && gl_SubgroupInvocationID == gl_SubgroupSize - 1u) rt_wsum[gl_SubgroupID] = incl;
        barrier();
        if (lid < RT_BATCH) {
            for (uint w = 0u; w < gl_SubgroupID; ++w) incl += rt_wsum[w];
            rt_scan[lid] = incl;
        }
        barrier();
        int src = 0;
#else
        barrier();
        int src = 0;   // Hillis-Steele inclusive scan (raster_segment.glsl's balanced form)
        for (int off = 1; off < RT_BATCH; off <<= 1) {
            int v = 0;
            if (lid < RT_BATCH) {
                v = rt_scan[src + lid];
                if (lid >= off) v += rt_scan[src + lid - off];
            }
            src = RT_BATCH - src;
            if (lid < RT_BATCH) rt_scan[src + lid] = v;
            barrier();
        }
#endif
        int total = rt_scan[src + RT_BATCH - 1];   // <= RT_BATCH x RT_SIDE
        int lo = 0, cur = -1, start = 0;
        RasterSpan t;
        uint id = 0u;
        for (int j = lid; j < total; j += RT_GROUP) {
            int hi = RT_BATCH - 1;
            while (lo < hi) {
                int mid = (lo + hi) >> 1;
                if (rt_scan[src + mid] > j) hi = mid; else lo = mid + 1;
            }
            if (lo != cur) {
                cur = lo;
                start = lo > 0 ? rt_scan[src + lo - 1] : 0;
                uvec4 ci = rt_ci[lo];
                t = raster_span_unpacked(rt_ad[lo], rt_zh[lo], ci, rt_xs[lo], rt_scan[src + lo] - start);
                id = ci.w;
            }
            int x = t.x0 + j - start;
            int y0, y1;
            float z, cov;
            raster_column_range(t, x, u_raster_size, y0, y1, z, cov);
            int n0 = t.steep ? t0.x : t0.y;   // the tile's rows along the minor axis
            y0 = max(y0, n0);
            y1 = min(y1, n0 + RT_SIDE - 1);
            if (y1 < y0) continue;
            ivec2 l0 = (t.steep ? ivec2(y0, x) : ivec2(x, y0)) - t0;
            ivec2 l1 = (t.steep ? ivec2(y1, x) : ivec2(x, y1)) - t0;
            uint bound = rt_bound(l0, l1);
            uint zb = floatBitsToUint(z);
            if (walk == 1 ? (z > 0.0 && zb >= bound) : (zb > bound)) {
#if RASTER_STATS
                if (walk == 1) {
                    g_scanned += uint(y1 - y0 + 1);
                    g_culled += uint(y1 - y0 + 1);
                }
#endif
                continue;
            }
            int step = t.steep ? 1 : RT_SIDE;
            int li = l0.y * RT_SIDE + l0.x;
            for (int yy = y0; yy <= y1; ++yy, li += step) rt_visit(walk, li, z, cov, id);
        }
    }
}

void raster_tiled_main() {
    int lid = int(gl_LocalInvocationID.x);
    int n = u_rt_tiles.x * u_rt_tiles.y;
    uint tile = rt_index[RT_HEADER + n + 1 + int(gl_WorkGroupID.x)];
    ivec2 t0 = ivec2(int(tile) % u_rt_tiles.x, int(tile) / u_rt_tiles.x) << RT_SHIFT;
    int width = u_raster_size.x / u_grid;
    for (int li = lid; li < RT_AREA; li += RT_GROUP) {
        ivec2 q = t0 + ivec2(li & (RT_SIDE - 1), li >> RT_SHIFT);
        uint d = VIS_EMPTY, id = 0u, c = COVER_SATURATED, head = 0u;   // past the grid: never visited
#if RT_PACKED
        uint64_t v = ~0ul;
#endif
        if (all(lessThan(q, u_raster_size))) {
            uint idx = sample_index(q, width, u_grid);
#if RT_PACKED
            v = vis[idx];
#elif VIS64
            uint64_t v = vis[idx];
            d = uint(v >> 32);
            id = uint(v & 0xFFFFFFFFul);
#else
            d = vis_depth[idx];
            id = vis_id[idx];
#endif
            c = cover[idx];
            head = floatBitsToUint(texelFetch(u_scene_depth, q / u_grid, 0).r);
        }
#if RT_PACKED
        rt_vis[li] = v;
#else
        rt_depth[li] = d;
        rt_id[li] = id;
#endif
        rt_cover[li] = c;
        rt_head[li] = head;
    }
    barrier();
    int begin = int(rt_index[RT_HEADER + tile]), end = int(rt_index[RT_HEADER + tile + 1u]);
    rt_walk(1, begin, end, t0);
    barrier();
#if !RT_PACKED
    // a depth this step lowered: the id an earlier step left no longer belongs to it
    for (int li = lid; li < RT_AREA; li += RT_GROUP) {
        ivec2 q = t0 + ivec2(li & (RT_SIDE - 1), li >> RT_SHIFT);
        if (!all(lessThan(q, u_raster_size))) continue;
        uint idx = sample_index(q, width, u_grid);
#if VIS64
        if (uint(vis[idx] >> 32) != rt_depth[li]) rt_id[li] = RT_EMPTY;
#else
        if (vis_depth[idx] != rt_depth[li]) rt_id[li] = 0u;
#endif
    }
    rt_walk(2, begin, end, t0);   // refreshes (barriers) before its first batch
    barrier();
#endif
    for (int li = lid; li < RT_AREA; li += RT_GROUP) {
        ivec2 q = t0 + ivec2(li & (RT_SIDE - 1), li >> RT_SHIFT);
        if (!all(lessThan(q, u_raster_size))) continue;
        uint idx = sample_index(q, width, u_grid);
#if RT_PACKED
        if (vis[idx] != rt_vis[li]) vis[idx] = rt_vis[li];
#elif VIS64
        uint64_t v = (uint64_t(rt_depth[li]) << 32) | uint64_t(rt_id[li]);
        if (vis[idx] != v) vis[idx] = v;
#else
        if (vis_depth[idx] != rt_depth[li]) vis_depth[idx] = rt_depth[li];
        if (vis_id[idx] != rt_id[li]) vis_id[idx] = rt_id[li];
#endif
        if (cover[idx] != rt_cover[li]) cover[idx] = rt_cover[li];
    }
}
#endif
