#version 430 core
#if ACC_FLOAT
#extension GL_NV_shader_atomic_float : require
#endif
// Grid friction, binned atomic splat: the same sums as splat_atomic.comp, but particles are first
// binned by tile (TILE_CELLS^3 cells, (TILE_CELLS + 1)^3 nodes) and each tile's particles are summed
// in shared memory; only the tile's touched nodes then go to the global accumulator. This turns
// 32 global atomics per particle (hot nodes near the scalp take thousands each) into shared-memory
// atomics, plus a few per tile node. Stages (one define each), every one a dispatch:
//
//   STAGE_COUNT    per particle: tile id (kept in TILE_OF(i) for the scatter, so both stages agree
//                  whatever the compiler does to the arithmetic); a shared histogram per work
//                  group, then one global atomicAdd per (group, touched tile) into COUNT(t)
//   STAGE_SCAN     one work group: exclusive prefix sum of the counts -> START(t) and CURSOR(t);
//                  START(NUM_TILES) = particles binned; clears the counts for the next step
//   STAGE_SCATTER  per particle: its rank in the group's shared histogram plus the group's slot
//                  range (one atomicAdd on CURSOR(t) per touched tile) -> ORDER(slot) = particle,
//                  and (SORTED_COPY) its position and velocity copied to slot in the sorted buffers
//   STAGE_SPLAT    balanced chunks of CHUNK sorted slots per work group, read through ORDER or
//                  (SORTED_COPY) from the sorted copies in slot order (contiguous: the particles
//                  of a tile come from strands all over the buffers, and gathering them through
//                  ORDER was the splat's whole cost at 1M guides: scattered 16-byte reads; up to
//                  500k guides the copies cost more than they save, docs/performance.md): for
//                  every tile segment of the chunk, clear a shared node tile, add each particle's
//                  8 corners to it, flush the touched nodes to the accumulator (grid_accum.glsl's
//                  format). A particle whose
//                  stencil the splat finds outside its tile (it cannot, unless the compiler rounds
//                  the two stages differently) goes straight to the accumulator. AGGREGATE (float
//                  atomics only): runs of particles in one cell are summed in registers first.
//
// CELL_SORT: the same stages sort by cell instead of by tile. The bin (sort key) is the cell in
// tile-major order, tile * TILE_CELLS^3 + the cell within the tile, so each tile's particles are
// still one contiguous range of slots (its start is its first cell's, TILE_START(t)) and within
// it each cell's particles are contiguous. That is what the splat's register runs (AGGREGATE) are
// for: an invocation's run of slots then mostly lies in one cell, so it flushes its 32 shared
// atomics about once a run instead of about once a particle (in tile order a strand's
// consecutive points rarely share a cell). The bins are too many for a shared histogram (262,144
// at 64^3 nodes, 2,097,152 at 129^3), so
//   STAGE_COUNT        one global atomicAdd on COUNT(bin) per particle;
//   STAGE_SCAN_BLOCKS  per work group, the sum of a block of SCAN_BLOCK counts -> BLOCK_SUM(g);
//   STAGE_SCAN         per work group, its block's offset (the sum of the block sums before it)
//                      plus the block's own exclusive scan -> START and CURSOR, clears the counts;
//                      the last group writes START(NUM_BINS) = particles binned;
//   STAGE_SCATTER      slot = atomicAdd(CURSOR(bin), 1) per particle (no shared ranks).
// A warp's lanes then mostly walk runs of the same cell, so their flushes would meet on the same
// 32 shared words at once (an earlier cell sort, reading through ORDER, measured slower for that
// and for its reads, docs/performance.md); with SPREAD_FLUSH each lane starts its flush at another
// of the 32 (corner, word) pairs (lane & 31), so 32 lanes of one cell add to 32 different words
// at each step.
//
// A particle that brings no mass (pinned with pinned_mass 0) or whose position is not finite is
// not binned (the direct splat would clamp a NaN onto some node; the NaN guard resets it anyway).
// In fixed point the shared sums are the same 64-bit words as the direct splat's, so the result is
// bit-identical to it; with float atomics it equals it up to float rounding (order-dependent).

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) readonly buffer Velocities { vec4 velocities[]; };
// B bins (tiles, or CELL_SORT cells): [0, B): counts, [B, 2B]: starts (START(B) = total),
// [2B + 1, 3B + 1): cursors, CELL_SORT: [3B + 1, 3B + 1 + scan blocks): block sums
layout(std430, binding = B_TILES) buffer Tiles { uint tiles[]; };
// [0, n): bin of each particle (NO_TILE: not splatted), [n, 2n): particles sorted by bin
layout(std430, binding = B_ORDER) buffer Order { uint order[]; };
#ifndef SORTED_COPY
#define SORTED_COPY 0
#endif
#if SORTED_COPY
// the position (w: inverse mass) and the velocity of the particle at each slot
layout(std430, binding = B_SORTED) buffer SortedPositions { vec4 sorted_p[]; };
layout(std430, binding = B_SORTED_VELOCITIES) buffer SortedVelocities { vec4 sorted_v[]; };
#endif
#include "grid_accum.glsl"
#include "grid_nodes.glsl"

// TILE_CELLS, TILES_AXIS (ceil((GRID_RES - 1) / TILE_CELLS)), CHUNK and PPT are injected
// (CELL_SORT: SCAN_BLOCK too).
#ifndef CELL_SORT
#define CELL_SORT 0
#endif
#define NUM_TILES uint(TILES_AXIS * TILES_AXIS * TILES_AXIS)
#if CELL_SORT
#define BINS_PER_TILE uint(TILE_CELLS * TILE_CELLS * TILE_CELLS)
#else
#define BINS_PER_TILE 1u
#endif
#define NUM_BINS (NUM_TILES * BINS_PER_TILE)
#define COUNT(b) tiles[(b)]
#define START(b) tiles[NUM_BINS + (b)]
#define CURSOR(b) tiles[2u * NUM_BINS + 1u + (b)]
#define BLOCK_SUM(g) tiles[3u * NUM_BINS + 1u + (g)]
#define TILE_START(t) START((t) * BINS_PER_TILE)   // TILE_START(NUM_TILES) = START(NUM_BINS)
#define BIN_OF(i) order[(i)]
#define ORDER(slot) order[num_particles + (slot)]
const uint NO_TILE = 0xffffffffu;

uniform uint num_particles;
uniform float pinned_mass;
uniform float inv_mass_unit;

bool finite3(vec3 v) {
    uvec3 e = floatBitsToUint(v) & uvec3(0x7f800000u);
    return all(notEqual(e, uvec3(0x7f800000u)));
}

// The bin of particle i: the tile that holds its stencil (CELL_SORT: its cell, tile-major), or
// NO_TILE when the particle is not splatted.
uint particle_bin(uint i) {
    vec4 p = positions[i];
    if (!(particle_mass(p.w, pinned_mass, inv_mass_unit) > 0.0) || !finite3(p.xyz)) return NO_TILE;
    ivec3 base = node_stencil(p.xyz).base;
    ivec3 t = clamp(base / TILE_CELLS, ivec3(0), ivec3(TILES_AXIS - 1));
    uint tile = uint(t.x + TILES_AXIS * (t.y + TILES_AXIS * t.z));
#if CELL_SORT
    ivec3 c = clamp(base - t * TILE_CELLS, ivec3(0), ivec3(TILE_CELLS - 1));
    return tile * BINS_PER_TILE + uint(c.x + TILE_CELLS * (c.y + TILE_CELLS * c.z));
#else
    return tile;
#endif
}

#if STAGE_COUNT || STAGE_SCATTER
layout(local_size_x = 256) in;
#if !CELL_SORT
shared uint s_hist[NUM_TILES];
#endif
#endif

#if STAGE_COUNT && CELL_SORT
void main() {
    uint first = gl_WorkGroupID.x * 256u * uint(PPT) + gl_LocalInvocationID.x;
    for (uint r = 0u; r < uint(PPT); ++r) {
        uint i = first + r * 256u;
        if (i >= num_particles) break;
        uint b = particle_bin(i);
        BIN_OF(i) = b;
        if (b != NO_TILE) atomicAdd(COUNT(b), 1u);
    }
}
#elif STAGE_COUNT
void main() {
    uint lid = gl_LocalInvocationID.x;
    for (uint t = lid; t < NUM_TILES; t += 256u) s_hist[t] = 0u;
    barrier();
    uint first = gl_WorkGroupID.x * 256u * uint(PPT) + lid;
    for (uint r = 0u; r < uint(PPT); ++r) {
        uint i = first + r * 256u;
        if (i >= num_particles) break;
        uint t = particle_bin(i);
        BIN_OF(i) = t;
        if (t != NO_TILE) atomicAdd(s_hist[t], 1u);
    }
    barrier();
    for (uint t = lid; t < NUM_TILES; t += 256u) {
        uint c = s_hist[t];
        if (c != 0u) atomicAdd(COUNT(t), c);
    }
}
#endif

#if (STAGE_SCAN_BLOCKS || STAGE_SCAN) && CELL_SORT
// SCAN_BLOCK = 256 * SCAN_PER bins a work group; NUM_BINS / SCAN_BLOCK blocks (at most 1024:
// STAGE_SCAN's offset sum reads 4 block sums an invocation at most)
layout(local_size_x = 256) in;
shared uint s_sum[256];
#define SCAN_PER (uint(SCAN_BLOCK) / 256u)

// the sum of s_sum[0..256) (every invocation calls it; leaves it in s_sum[0])
uint group_sum(uint lid, uint mine) {
    s_sum[lid] = mine;
    barrier();
    for (uint half_ = 128u; half_ > 0u; half_ >>= 1) {
        if (lid < half_) s_sum[lid] += s_sum[lid + half_];
        barrier();
    }
    uint total = s_sum[0];
    barrier();                                 // s_sum is reused next
    return total;
}
#endif

#if STAGE_SCAN_BLOCKS && CELL_SORT
void main() {
    uint lid = gl_LocalInvocationID.x, g = gl_WorkGroupID.x;
    uint mine = 0u;
    for (uint r = 0u; r < SCAN_PER; ++r) {     // coalesced: consecutive invocations, consecutive bins
        uint b = g * uint(SCAN_BLOCK) + r * 256u + lid;
        if (b < NUM_BINS) mine += COUNT(b);
    }
    uint total = group_sum(lid, mine);
    if (lid == 0u) BLOCK_SUM(g) = total;
}
#endif

#if STAGE_SCAN && CELL_SORT
void main() {
    uint lid = gl_LocalInvocationID.x, g = gl_WorkGroupID.x;
    uint before = 0u;                          // the bins of the blocks before this one
    for (uint k = lid; k < g; k += 256u) before += BLOCK_SUM(k);
    uint offset = group_sum(lid, before);
    // SCAN_PER consecutive bins an invocation (a warp reads 32 * SCAN_PER consecutive words)
    uint b0 = g * uint(SCAN_BLOCK) + lid * SCAN_PER;
    uint mine = 0u;
    for (uint r = 0u; r < SCAN_PER; ++r)
        if (b0 + r < NUM_BINS) mine += COUNT(b0 + r);
    s_sum[lid] = mine;
    barrier();
    for (uint off = 1u; off < 256u; off <<= 1) {   // Hillis-Steele inclusive scan
        uint add = lid >= off ? s_sum[lid - off] : 0u;
        barrier();
        s_sum[lid] += add;
        barrier();
    }
    uint run = offset + s_sum[lid] - mine;
    for (uint r = 0u; r < SCAN_PER; ++r) {
        uint b = b0 + r;
        if (b < NUM_BINS) {
            uint c = COUNT(b);
            START(b) = run;
            CURSOR(b) = run;
            COUNT(b) = 0u;
            run += c;
        }
    }
    if (g == gl_NumWorkGroups.x - 1u && lid == 255u) START(NUM_BINS) = offset + s_sum[255];
}
#endif

#if STAGE_SCAN && !CELL_SORT
layout(local_size_x = 1024) in;
shared uint s_sum[1024];
void main() {
    uint lid = gl_LocalInvocationID.x;
    const uint PER = (NUM_TILES + 1023u) / 1024u;
    uint t0 = lid * PER;
    uint mine = 0u;
    for (uint k = 0u; k < PER; ++k)
        if (t0 + k < NUM_TILES) mine += COUNT(t0 + k);
    s_sum[lid] = mine;
    barrier();
    for (uint off = 1u; off < 1024u; off <<= 1) {   // Hillis-Steele inclusive scan
        uint add = lid >= off ? s_sum[lid - off] : 0u;
        barrier();
        s_sum[lid] += add;
        barrier();
    }
    uint run = s_sum[lid] - mine;
    for (uint k = 0u; k < PER; ++k) {
        uint t = t0 + k;
        if (t < NUM_TILES) {
            uint c = COUNT(t);
            START(t) = run;
            CURSOR(t) = run;
            COUNT(t) = 0u;
            run += c;
        }
    }
    if (lid == 1023u) START(NUM_TILES) = s_sum[1023];
}
#endif

#if STAGE_SCATTER && CELL_SORT
void main() {
    uint first = gl_WorkGroupID.x * 256u * uint(PPT) + gl_LocalInvocationID.x;
    for (uint r = 0u; r < uint(PPT); ++r) {
        uint i = first + r * 256u;
        if (i >= num_particles) break;
        uint b = BIN_OF(i);
        if (b == NO_TILE) continue;
        uint slot = atomicAdd(CURSOR(b), 1u);
        ORDER(slot) = i;
#if SORTED_COPY
        sorted_p[slot] = positions[i];
        sorted_v[slot] = velocities[i];
#endif
    }
}
#elif STAGE_SCATTER
void main() {
    uint lid = gl_LocalInvocationID.x;
    for (uint t = lid; t < NUM_TILES; t += 256u) s_hist[t] = 0u;
    barrier();
    uint first = gl_WorkGroupID.x * 256u * uint(PPT) + lid;
    uint tile[PPT];
    uint rank[PPT];
    for (uint r = 0u; r < uint(PPT); ++r) {
        uint i = first + r * 256u;
        tile[r] = i < num_particles ? BIN_OF(i) : NO_TILE;
        rank[r] = 0u;
        if (tile[r] != NO_TILE) rank[r] = atomicAdd(s_hist[tile[r]], 1u);
    }
    barrier();
    for (uint t = lid; t < NUM_TILES; t += 256u) {   // the group's slots in each touched tile
        uint c = s_hist[t];
        if (c != 0u) s_hist[t] = atomicAdd(CURSOR(t), c);
    }
    barrier();
    for (uint r = 0u; r < uint(PPT); ++r)
        if (tile[r] != NO_TILE) {
            uint i = first + r * 256u, slot = s_hist[tile[r]] + rank[r];
            ORDER(slot) = i;
#if SORTED_COPY
            sorted_p[slot] = positions[i];
            sorted_v[slot] = velocities[i];
#endif
        }
}
#endif

#if STAGE_SPLAT
#if !defined(AGGREGATE) || !ACC_FLOAT
#undef AGGREGATE
#define AGGREGATE 0
#endif
#ifndef SPREAD_FLUSH
#define SPREAD_FLUSH 0
#endif
layout(local_size_x = 256) in;
#define TN (TILE_CELLS + 1)
#define TILE_NODES uint(TN * TN * TN)
// structure of arrays: word w of node j at s_acc[w * TILE_NODES + j], so that a warp's lanes,
// adding to different nodes, spread over the 32 banks (4 or 8 words per node interleaved would
// put every lane's word w on one of 8 or 4 banks)
#if ACC_FLOAT
shared float s_acc[TILE_NODES * 4u];
#else
shared uint s_acc[TILE_NODES * 8u];
#endif
#define S_ACC(w, j) s_acc[(w) * TILE_NODES + (j)]

// The position (w: inverse mass) and the velocity of the particle at sorted slot `slot`.
void slot_particle(uint slot, out vec4 p, out vec3 v) {
#if SORTED_COPY
    p = sorted_p[slot];
    v = sorted_v[slot].xyz;
#else
    uint i = ORDER(slot);
    p = positions[i];
    v = velocities[i].xyz;
#endif
}

void tile_add(uint j, float m, vec3 mv) {
#if ACC_FLOAT
    atomicAdd(S_ACC(0u, j), m);
    atomicAdd(S_ACC(1u, j), mv.x);
    atomicAdd(S_ACC(2u, j), mv.y);
    atomicAdd(S_ACC(3u, j), mv.z);
#else
    vec4 value = vec4(m, mv);
    for (uint k = 0u; k < 4u; ++k) {
        uvec2 w = fixed_words(value[k]);
        if (w != uvec2(0u)) {
            uint old = atomicAdd(S_ACC(2u * k, j), w.x);
            uint carry = (old + w.x < old) ? 1u : 0u;
            atomicAdd(S_ACC(2u * k + 1u, j), w.y + carry);
        }
    }
#endif
}

void tile_flush(uint j, uint node) {
#if ACC_FLOAT
    vec4 a = vec4(S_ACC(0u, j), S_ACC(1u, j), S_ACC(2u, j), S_ACC(3u, j));
    if (a != vec4(0.0)) {
        uint b = node * 4u;
        for (uint k = 0u; k < 4u; ++k)
            if (a[k] != 0.0) atomicAdd(acc[b + k], a[k]);
    }
#else
    for (uint k = 0u; k < 4u; ++k) {
        uvec2 w = uvec2(S_ACC(2u * k, j), S_ACC(2u * k + 1u, j));
        if (w != uvec2(0u)) FIXED_ADD_WORDS(acc, node * 8u + 2u * k, w)
    }
#endif
}

#if AGGREGATE
// AGGREGATE (float atomics only): an invocation's run of sorted slots is mostly consecutive
// particles of a strand, and consecutive particles often share a cell: their 8 corner
// contributions (m w, m w v) are summed in registers while the cell stays the same, and go to
// the tile (or the accumulator) when it changes: fewer shared atomics, the same sums up to float
// rounding (float atomics are order-dependent anyway).
void run_clear(inout vec4 run[8]) {
    for (int c = 0; c < 8; ++c) run[c] = vec4(0.0);
}

void run_flush(vec4 run[8], ivec3 base, ivec3 origin) {
    ivec3 local = base - origin;
    bool inside = all(greaterThanEqual(local, ivec3(0))) && all(lessThan(local, ivec3(TILE_CELLS)));
#if SPREAD_FLUSH
    if (inside) {
        // lane l starts at corner l & 7 and word (l >> 3) & 3: the 8 corners rotated by s and each
        // corner's 4 words by u in registers (constant indices: selects, not a dynamically indexed
        // array in local memory), then corner (c + s) & 7's word (k + u) & 3 is r[c][k]
        uint lane = gl_LocalInvocationID.x;
        int s = int(lane & 7u), u = int((lane >> 3) & 3u);
        vec4 r[8] = run;
        if ((s & 1) != 0) r = vec4[8](r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[0]);
        if ((s & 2) != 0) r = vec4[8](r[2], r[3], r[4], r[5], r[6], r[7], r[0], r[1]);
        if ((s & 4) != 0) r = vec4[8](r[4], r[5], r[6], r[7], r[0], r[1], r[2], r[3]);
        for (int c = 0; c < 8; ++c) {
            if (r[c].x == 0.0) continue;       // no mass at this corner (before the words turn)
            vec4 a = (u & 1) != 0 ? r[c].yzwx : r[c];
            a = (u & 2) != 0 ? a.zwxy : a;
            int cc = (c + s) & 7;
            ivec3 l = local + ivec3(cc & 1, (cc >> 1) & 1, (cc >> 2) & 1);
            uint j = uint(l.x + TN * (l.y + TN * l.z));
            for (int k = 0; k < 4; ++k) atomicAdd(S_ACC(uint((k + u) & 3), j), a[k]);
        }
        return;
    }
#endif
    for (int c = 0; c < 8; ++c) {
        vec4 a = run[c];
        if (a.x == 0.0) continue;
        ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        if (inside) {
            ivec3 l = local + corner;
            tile_add(uint(l.x + TN * (l.y + TN * l.z)), a.x, a.yzw);
        } else {
            acc_add(node_index(base + corner), a.x, a.yzw);
        }
    }
}

// The particle at sorted slot `slot` into the run of register sums (cell: the run's cell, -1 for none yet).
void run_particle(uint slot, inout ivec3 cell, inout vec4 run[8], ivec3 origin) {
    vec4 p;
    vec3 v;
    slot_particle(slot, p, v);
    float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
    NodeStencil s = node_stencil(p.xyz);
    if (s.base != cell) {
        if (cell.x >= 0) run_flush(run, cell, origin);
        cell = s.base;
        run_clear(run);
    }
    for (int c = 0; c < 8; ++c) {
        ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        float mw = m * corner_weight(s.frac, corner);
        run[c] += vec4(mw, mw * v);
    }
}
#endif

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint total = START(NUM_BINS);
    uint pos = gl_WorkGroupID.x * uint(CHUNK);
    if (pos >= total) return;                  // the whole group: no barrier is skipped by part of it
    uint last = min(pos + uint(CHUNK), total);
    // the tile whose slots hold pos: the last t with TILE_START(t) <= pos (binary search; empty
    // tiles have TILE_START(t) == TILE_START(t + 1))
    uint lo = 0u, hi = NUM_TILES;               // TILE_START(lo) <= pos < TILE_START(hi)
    while (hi - lo > 1u) {
        uint mid = (lo + hi) >> 1;
        if (TILE_START(mid) <= pos) lo = mid; else hi = mid;
    }
    uint t = lo;
    while (pos < last) {                       // group-uniform: every invocation takes the same path
        while (TILE_START(t + 1u) <= pos) ++t;
        uint seg_end = min(last, TILE_START(t + 1u));
        ivec3 origin = ivec3(int(t) % TILES_AXIS, (int(t) / TILES_AXIS) % TILES_AXIS,
                             int(t) / (TILES_AXIS * TILES_AXIS)) * TILE_CELLS;
#if ACC_FLOAT
        for (uint j = lid; j < TILE_NODES * 4u; j += 256u) s_acc[j] = 0.0;
#else
        for (uint j = lid; j < TILE_NODES * 8u; j += 256u) s_acc[j] = 0u;
#endif
        barrier();
        // each invocation takes a contiguous run of slots: neighbouring slots are mostly
        // neighbouring particles of one strand (same cell), so interleaving them across lanes
        // would make a warp's shared atomics collide on the same node
        uint per = (seg_end - pos + 255u) / 256u;
        uint run_end = min(seg_end, pos + (lid + 1u) * per);
#if AGGREGATE
        ivec3 cell = ivec3(-1);
        vec4 run[8];                           // per corner: (m w, m w v) of the run
        run_clear(run);
        for (uint slot = pos + lid * per; slot < run_end; ++slot) run_particle(slot, cell, run, origin);
        if (cell.x >= 0) run_flush(run, cell, origin);
#else
        for (uint slot = pos + lid * per; slot < run_end; ++slot) {
            vec4 p;
            vec3 v;
            slot_particle(slot, p, v);
            float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
            NodeStencil s = node_stencil(p.xyz);
            ivec3 local = s.base - origin;     // in [0, TILE_CELLS - 1]^3
            bool inside = all(greaterThanEqual(local, ivec3(0))) && all(lessThan(local, ivec3(TILE_CELLS)));
            for (int q = 0; q < 8; ++q) {
#if SPREAD_FLUSH
                int c = (q + int(lid)) & 7;    // lanes of one cell start at different corners
#else
                int c = q;
#endif
                ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
                float mw = m * corner_weight(s.frac, corner);
                if (mw == 0.0) continue;
                ivec3 l = local + corner;
                if (inside) tile_add(uint(l.x + TN * (l.y + TN * l.z)), mw, mw * v);
                else acc_add(node_index(s.base + corner), mw, mw * v);
            }
        }
#endif
        barrier();
        for (uint j = lid; j < TILE_NODES; j += 256u) {
            ivec3 l = ivec3(int(j) % TN, (int(j) / TN) % TN, int(j) / (TN * TN));
            ivec3 n = origin + l;
            if (all(lessThan(n, ivec3(GRID_RES)))) tile_flush(j, node_index(n));
        }
        barrier();
        pos = seg_end;
    }
}
#endif
