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
//                  or (SORTED_COPY) its position and velocity copied to slot in the sorted buffers
//                  (the splat then reads only those: ORDER is left unwritten, 4 scattered bytes a
//                  particle fewer)
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
// CELL_SORT (the splat only; the tile sort above is unchanged): a work group walks each tile
// segment of its chunk in cell order rather than slot order. In slot order a strand's
// consecutive points rarely share a cell, so a run of register sums (AGGREGATE) is short; in
// cell order an invocation's run mostly lies in one cell and flushes its 32 shared atomics about
// once a run. Per segment (CHUNK = 256 x CELL_RUN slots at most):
//   1. each invocation takes slots pos + r * 256 + lid (r < CELL_RUN: coalesced), computes the
//      particle's cell within the tile (0..511) and its rank in that cell with one shared
//      atomicAdd on s_cells (a histogram), keeping (cell << 16 | rank) in registers; a particle
//      whose stencil falls outside the tile (the guard: it cannot, unless the compiler rounds the
//      count stage and this one differently) goes straight to the accumulator here;
//   2. an exclusive scan of the 512 counts in shared memory -> each cell's first position;
//   3. s_perm[cell's start + rank] = slot - pos (16 bits each, two a word, atomicOr into a
//      cleared array: CHUNK <= 65536);
//   4. each invocation walks a contiguous run of the cell-ordered positions, reading each
//      particle from its slot (within the chunk: cache-friendly with the sorted copies).
// Which cell a particle is counted in only decides the order: the walk recomputes each
// particle's stencil and its runs and the tile guard use that, so the sums do not depend on
// the two computations agreeing. With SPREAD_FLUSH a warp's lanes, mostly in one cell, start
// their 32 shared atomics at different (corner, word) pairs (lane & 31), so they do not meet on
// the same shared word at once.
//
// A particle that brings no mass (pinned with pinned_mass 0) or whose position is not finite is
// not binned (the direct splat would clamp a NaN onto some node; the NaN guard resets it anyway).
// In fixed point the shared sums are the same 64-bit words as the direct splat's, so the result is
// bit-identical to it; with float atomics it equals it up to float rounding (order-dependent).

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) readonly buffer Velocities { vec4 velocities[]; };
// [0, T): counts, [T, 2T]: starts (START(T) = total), [2T + 1, 3T + 1): cursors
layout(std430, binding = B_TILES) buffer Tiles { uint tiles[]; };
// [0, n): tile of each particle (NO_TILE: not splatted), [n, 2n): particles sorted by tile
layout(std430, binding = B_ORDER) buffer Order { uint order[]; };
#ifndef SORTED_COPY
#define SORTED_COPY 0
#endif
#if SORTED_COPY
// the position (w: inverse mass) and the velocity of the particle at each slot, side by side: one
// 32-byte record a particle (two buffers of 16-byte halves with the order written too, and a
// packed 28-byte record, were slower to write: docs/performance.md)
layout(std430, binding = B_SORTED) buffer Sorted { vec4 sorted_pv[]; };
void copy_write(uint slot, vec4 p, vec4 v) {
    sorted_pv[2u * slot] = p;
    sorted_pv[2u * slot + 1u] = v;
}
vec4 copy_position(uint slot) { return sorted_pv[2u * slot]; }
vec3 copy_velocity(uint slot) { return sorted_pv[2u * slot + 1u].xyz; }
#endif
#include "grid_accum.glsl"
#include "grid_nodes.glsl"

// TILE_CELLS, TILES_AXIS (ceil((GRID_RES - 1) / TILE_CELLS)), CHUNK and PPT are injected.
#define NUM_TILES uint(TILES_AXIS * TILES_AXIS * TILES_AXIS)
#define COUNT(t) tiles[(t)]
#define START(t) tiles[NUM_TILES + (t)]
#define CURSOR(t) tiles[2u * NUM_TILES + 1u + (t)]
#define TILE_OF(i) order[(i)]
#define ORDER(slot) order[num_particles + (slot)]
const uint NO_TILE = 0xffffffffu;

uniform uint num_particles;
uniform float pinned_mass;
uniform float inv_mass_unit;

bool finite3(vec3 v) {
    uvec3 e = floatBitsToUint(v) & uvec3(0x7f800000u);
    return all(notEqual(e, uvec3(0x7f800000u)));
}

// The tile that holds particle i's stencil, or NO_TILE when the particle is not splatted.
uint particle_tile(uint i) {
    vec4 p = positions[i];
    if (!(particle_mass(p.w, pinned_mass, inv_mass_unit) > 0.0) || !finite3(p.xyz)) return NO_TILE;
    ivec3 t = clamp(node_stencil(p.xyz).base / TILE_CELLS, ivec3(0), ivec3(TILES_AXIS - 1));
    return uint(t.x + TILES_AXIS * (t.y + TILES_AXIS * t.z));
}

#if STAGE_COUNT || STAGE_SCATTER
layout(local_size_x = 256) in;
shared uint s_hist[NUM_TILES];
#endif

#if STAGE_COUNT
void main() {
    uint lid = gl_LocalInvocationID.x;
    for (uint t = lid; t < NUM_TILES; t += 256u) s_hist[t] = 0u;
    barrier();
    uint first = gl_WorkGroupID.x * 256u * uint(PPT) + lid;
    for (uint r = 0u; r < uint(PPT); ++r) {
        uint i = first + r * 256u;
        if (i >= num_particles) break;
        uint t = particle_tile(i);
        TILE_OF(i) = t;
        if (t != NO_TILE) atomicAdd(s_hist[t], 1u);
    }
    barrier();
    for (uint t = lid; t < NUM_TILES; t += 256u) {
        uint c = s_hist[t];
        if (c != 0u) atomicAdd(COUNT(t), c);
    }
}
#endif

#if STAGE_SCAN
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

#if STAGE_SCATTER
void main() {
    uint lid = gl_LocalInvocationID.x;
    for (uint t = lid; t < NUM_TILES; t += 256u) s_hist[t] = 0u;
    barrier();
    uint first = gl_WorkGroupID.x * 256u * uint(PPT) + lid;
    uint tile[PPT];
    uint rank[PPT];
    for (uint r = 0u; r < uint(PPT); ++r) {
        uint i = first + r * 256u;
        tile[r] = i < num_particles ? TILE_OF(i) : NO_TILE;
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
#if SORTED_COPY
            copy_write(slot, positions[i], velocities[i]);
#else
            ORDER(slot) = i;
#endif
        }
}
#endif

#if STAGE_SPLAT
#if !defined(AGGREGATE) || !ACC_FLOAT
#undef AGGREGATE
#define AGGREGATE 0
#endif
#ifndef CELL_SORT
#define CELL_SORT 0
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
#if CELL_SORT
#if TILE_CELLS != 8 || (CHUNK % 256) != 0 || CHUNK > 65536
#error "CELL_SORT: 8^3 cells a tile (two an invocation in the scan), CHUNK a multiple of 256 up to 65536"
#endif
#define CELL_RUN (CHUNK / 256)
#define TILE_CELL_COUNT 512u
const uint OUTSIDE = 0xffffffffu;
shared uint s_cells[TILE_CELL_COUNT];   // per cell of the tile: counts, then first positions
shared uint s_scan[256];
shared uint s_perm[CHUNK / 2];          // cell-ordered position k -> slot - pos, 16 bits each
#define PERM_SLOT(k) ((s_perm[(k) >> 1] >> (((k) & 1u) * 16u)) & 0xffffu)
#endif

// The position (w: inverse mass) and the velocity of the particle at sorted slot `slot`.
void slot_particle(uint slot, out vec4 p, out vec3 v) {
#if SORTED_COPY
    p = copy_position(slot);
    v = copy_velocity(slot);
#else
    uint i = ORDER(slot);
    p = positions[i];
    v = velocities[i].xyz;
#endif
}

#if CELL_SORT
// The position (w: inverse mass) of the particle at sorted slot `slot`.
vec4 slot_position(uint slot) {
#if SORTED_COPY
    return copy_position(slot);
#else
    return positions[ORDER(slot)];
#endif
}

bool in_tile(ivec3 local) {
    return all(greaterThanEqual(local, ivec3(0))) && all(lessThan(local, ivec3(TILE_CELLS)));
}

// The particle at sorted slot `slot` straight to the accumulator (its stencil is outside the tile).
void particle_to_accumulator(uint slot) {
    vec4 p;
    vec3 v;
    slot_particle(slot, p, v);
    float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
    NodeStencil s = node_stencil(p.xyz);
    for (int c = 0; c < 8; ++c) {
        ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        float mw = m * corner_weight(s.frac, corner);
        if (mw != 0.0) acc_add(node_index(s.base + corner), mw, mw * v);
    }
}
#endif

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
    uint total = START(NUM_TILES);
    uint pos = gl_WorkGroupID.x * uint(CHUNK);
    if (pos >= total) return;                  // the whole group: no barrier is skipped by part of it
    uint last = min(pos + uint(CHUNK), total);
    // the tile whose slots hold pos: the last t with START(t) <= pos (binary search; empty tiles
    // have START(t) == START(t + 1))
    uint lo = 0u, hi = NUM_TILES;               // START(lo) <= pos < START(hi)
    while (hi - lo > 1u) {
        uint mid = (lo + hi) >> 1;
        if (START(mid) <= pos) lo = mid; else hi = mid;
    }
    uint t = lo;
    while (pos < last) {                       // group-uniform: every invocation takes the same path
        while (START(t + 1u) <= pos) ++t;
        uint seg_end = min(last, START(t + 1u));
        ivec3 origin = ivec3(int(t) % TILES_AXIS, (int(t) / TILES_AXIS) % TILES_AXIS,
                             int(t) / (TILES_AXIS * TILES_AXIS)) * TILE_CELLS;
#if ACC_FLOAT
        for (uint j = lid; j < TILE_NODES * 4u; j += 256u) s_acc[j] = 0.0;
#else
        for (uint j = lid; j < TILE_NODES * 8u; j += 256u) s_acc[j] = 0u;
#endif
#if CELL_SORT
        for (uint j = lid; j < TILE_CELL_COUNT; j += 256u) s_cells[j] = 0u;
        for (uint j = lid; j < uint(CHUNK) / 2u; j += 256u) s_perm[j] = 0u;
        barrier();
        // 1. each slot's cell within the tile and its rank there (registers: constant indices
        //    once the loop is unrolled)
        uint key[CELL_RUN];                    // cell << 16 | rank, or OUTSIDE
        for (uint r = 0u; r < uint(CELL_RUN); ++r) {
            uint slot = pos + r * 256u + lid;
            key[r] = OUTSIDE;
            if (slot < seg_end) {
                ivec3 local = node_stencil(slot_position(slot).xyz).base - origin;
                if (in_tile(local)) {
                    uint c = uint(local.x + TILE_CELLS * (local.y + TILE_CELLS * local.z));
                    key[r] = (c << 16) | atomicAdd(s_cells[c], 1u);
                } else {
                    particle_to_accumulator(slot);   // the guard: not in the walk
                }
            }
        }
        barrier();
        // 2. exclusive scan of the 512 counts: two an invocation, a Hillis-Steele scan of the pairs
        uint c0 = s_cells[2u * lid], c1 = s_cells[2u * lid + 1u];
        s_scan[lid] = c0 + c1;
        barrier();
        for (uint off = 1u; off < 256u; off <<= 1) {
            uint add = lid >= off ? s_scan[lid - off] : 0u;
            barrier();
            s_scan[lid] += add;
            barrier();
        }
        uint inclusive = s_scan[lid];
        s_cells[2u * lid] = inclusive - c1 - c0;
        s_cells[2u * lid + 1u] = inclusive - c1;
        uint walk = s_scan[255];               // particles of the segment in the tile
        barrier();
        // 3. the permutation: cell-ordered position -> slot - pos
        for (uint r = 0u; r < uint(CELL_RUN); ++r) {
            if (key[r] == OUTSIDE) continue;
            uint k = s_cells[key[r] >> 16] + (key[r] & 0xffffu);
            atomicOr(s_perm[k >> 1], (r * 256u + lid) << ((k & 1u) * 16u));
        }
        barrier();
#define WALK_SLOT(k) (pos + PERM_SLOT(k))
#else
        barrier();
        uint walk = seg_end - pos;
#define WALK_SLOT(k) (pos + (k))
#endif
        // each invocation takes a contiguous run of slots (CELL_SORT: of cell-ordered positions):
        // neighbouring slots are mostly neighbouring particles of one strand (same cell), so
        // interleaving them across lanes would make a warp's shared atomics collide on the same node
        uint per = (walk + 255u) / 256u;
        uint k_end = min(walk, (lid + 1u) * per);
#if AGGREGATE
        ivec3 cell = ivec3(-1);
        vec4 run[8];                           // per corner: (m w, m w v) of the run
        run_clear(run);
        for (uint k = lid * per; k < k_end; ++k) run_particle(WALK_SLOT(k), cell, run, origin);
        if (cell.x >= 0) run_flush(run, cell, origin);
#else
        for (uint k = lid * per; k < k_end; ++k) {
            uint slot = WALK_SLOT(k);
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
#undef WALK_SLOT
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
