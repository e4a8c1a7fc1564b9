#version 430
// The OIT methods' fill by the compute rasteriser (oit/compute.py): every segment of the
// expanded strands, scan-converted by passes/raster_segment.glsl with one sample per pixel;
// each fragment in front of the head (its window depth below the scene's) goes to the
// method's per-pixel storage. OIT_CM (method) / OIT_PASS:
//   1 A-buffer    0: linked lists (head pointers, a node pool {depth bits, segment, next}, a counter)
//   2 K-buffer    the OIT_K nearest keys per pixel (slots, ascending, pixel-major), kept by an
//                 atomicMin insertion cascade; a fragment pushed out of the last slot is shaded and
//                 added to the pixel's tail sums (colour, alpha, optical depth, count).
//                 OIT_ATOMIC64: one pass, key = depth bits << 32 | segment.
//                 Else 0: keys = depth bits; 1: each fragment claims a slot holding its depth
//                 (atomicCompSwap of the slot's id), the others go to the tail.
//   3 DBK-buffer  0: nearest depth per pixel (front); 1 (and 2 without 64-bit atomics): the
//                 fragments within u_oit_shift (m) of the front as the K-buffer's, the nearest of
//                 the others (behind; 32-bit: its depth in 1, its segment in 2) and the sum of
//                 their optical depths.
//   4 ShortCut    the 3 nearest as the K-buffer's (no tail) plus every fragment's optical depth.
//   9 capture     0: count the fragments; 1: every fragment's record (tests' exact reference).
#if OIT_ATOMIC64
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_NV_shader_atomic_int64 : require
#endif
layout(local_size_x = 128) in;
#if OIT_SHADING
#include "shading/hair_shading.glsl"
#include "passes/hair_radiance.glsl"
#endif
#include "compute_oit.glsl"

uniform sampler2D u_scene_depth;   // the head's window depth per pixel
uniform int u_num_segments;        // rendered strands x (points - 1)
uniform float u_oit_shift;         // DBK: the layer's depth behind the front (m)
uniform uint u_oit_capacity;       // A-buffer / capture: nodes / records

#if OIT_CM == 1
layout(std430, binding = B_OIT_HEADS) buffer Heads { uint heads[]; };
layout(std430, binding = B_OIT_NODES) writeonly buffer Nodes { uint nodes[]; };   // 3 words a node
layout(std430, binding = B_OIT_COUNTER) buffer Counter { uint counter[]; };
#endif

#if OIT_CM == 2 || OIT_CM == 3 || OIT_CM == 4
#define OIT_SLOTS 1
#if OIT_ATOMIC64
layout(std430, binding = B_OIT_SLOTS) buffer Slots { uint64_t slots[]; };
#define SLOT_EMPTY 0xFFFFFFFFFFFFFFFFul
#else
layout(std430, binding = B_OIT_SLOTS) buffer Slots { uint slots[]; };
layout(std430, binding = B_OIT_SLOT_IDS) buffer SlotIds { uint slot_ids[]; };
#define SLOT_EMPTY OIT_EMPTY
#endif
// K-buffer, DBK (tail_words words a pixel, word-major; compute_oit.glsl's TW_*): OIT_TAIL_SHADED
// rgb, alpha (x OIT_SCALE), optical depth, count; else alpha, optical depth, count.
// ShortCut: word 0, every fragment's optical depth.
layout(std430, binding = B_OIT_TAIL) buffer Tail { uint tail[]; };
#endif

#if OIT_CM == 3
layout(std430, binding = B_OIT_FRONT) buffer Front { uint front[]; };
#if OIT_ATOMIC64
layout(std430, binding = B_OIT_BEHIND) buffer Behind { uint64_t behind[]; };
#else
layout(std430, binding = B_OIT_BEHIND) buffer Behind { uint behind[]; };   // depth bits, then id + 1
#endif
layout(std430, binding = B_OIT_BEHIND_OPTICAL) buffer BehindOptical { uint behind_optical[]; };   // all behind: -log(T)
#endif

#if OIT_CM == 9
layout(std430, binding = B_OIT_COUNTER) buffer Counter { uint counter[]; };
layout(std430, binding = B_OIT_RECORDS) writeonly buffer Records { uint records[]; };   // 8 words a fragment
#endif

uint g_id;   // the visited segment (its first point's index in the expanded buffer; RASTER_SEGMENT)

#if OIT_SLOTS
// a fragment out of the slots (segment seg at pixel q; cov: its coverage when it is this
// thread's own, < 0: recompute) into the pixel's tail sums
#if OIT_CM != 4 && OIT_TAIL_SHADED && OIT_SHADING
void tail_add(uint seg, ivec2 q, uint p, float cov) {
    uint P = oit_num_pixels();
    vec4 c = oit_shade(seg, q);
    atomicAdd(tail[TW_R * P + p], oit_units(c.r));
    atomicAdd(tail[TW_G * P + p], oit_units(c.g));
    atomicAdd(tail[TW_B * P + p], oit_units(c.b));
    atomicAdd(tail[TW_A * P + p], oit_units(c.a));
    atomicAdd(tail[TW_OPT * P + p], oit_optical_units(c.a));
    atomicAdd(tail[TW_N * P + p], 1u);
}
#elif OIT_CM != 4 && !OIT_TAIL_SHADED
void tail_add(uint seg, ivec2 q, uint p, float cov) {
    uint P = oit_num_pixels();
    float a = oit_alpha_of(cov >= 0.0 ? cov : oit_coverage(oit_segment(seg), q));
    atomicAdd(tail[TW_A * P + p], oit_units(a));
    atomicAdd(tail[TW_OPT * P + p], oit_optical_units(a));
    atomicAdd(tail[TW_N * P + p], 1u);
}
#else
void tail_add(uint seg, ivec2 q, uint p, float cov) {}
#endif

#if OIT_ATOMIC64
// keep the OIT_K smallest keys of the pixel, ascending in slots[p * OIT_K ..]; a key pushed out
// of the last slot goes to the tail. A slot's value only ever decreases, so a plain (possibly
// stale) read at or below the carried key means the atomicMin there would change nothing.
void insert_key(uint zb, ivec2 q, uint p, float cov) {
    uint64_t own = (uint64_t(zb) << 32) | uint64_t(g_id);
    uint64_t v = own;
    uint base = p * uint(OIT_K);
    if (slots[base + uint(OIT_K - 1)] < v) {   // behind a full set of slots: straight to the tail
        tail_add(g_id, q, p, cov);
        return;
    }
    for (int i = 0; i < OIT_K; ++i) {
        if (slots[base + uint(i)] <= v) continue;
        uint64_t old = atomicMin(slots[base + uint(i)], v);
        if (old == SLOT_EMPTY) { v = SLOT_EMPTY; break; }
        v = old > v ? old : v;
    }
    if (v != SLOT_EMPTY) tail_add(uint(v & 0xFFFFFFFFul), q, p, v == own ? cov : -1.0);
}
#else
void insert_key(uint zb, ivec2 q, uint p, float cov) {
    uint v = zb;
    uint base = p * uint(OIT_K);
    if (slots[base + uint(OIT_K - 1)] < v) return;   // behind a full set of slots
    for (int i = 0; i < OIT_K; ++i) {
        if (slots[base + uint(i)] <= v) continue;
        uint old = atomicMin(slots[base + uint(i)], v);
        if (old == SLOT_EMPTY) break;
        v = max(old, v);
    }
}
// second pass: the fragment's depth among the kept ones -> it claims that slot; else the tail
void claim_slot(uint zb, ivec2 q, uint p, float cov) {
    uint base = p * uint(OIT_K);
    bool kept = false;
    for (int i = 0; i < OIT_K; ++i) {
        uint s = slots[base + uint(i)];
        if (s > zb) break;
        if (s == zb && atomicCompSwap(slot_ids[base + uint(i)], OIT_EMPTY, g_id) == OIT_EMPTY) {
            kept = true;
            break;
        }
    }
    if (!kept) tail_add(g_id, q, p, cov);
}
#endif
#endif

#ifndef RASTER_HEAD_CULL
#define RASTER_HEAD_CULL 0
#endif
#if RASTER_HEAD_CULL
// segments and columns at or behind the head's depth tile map (passes/depth_tiles.py): each of
// their fragments would fail visit()'s `z >= scene depth`, so none is visited
#include "passes/depth_tiles.glsl"
#define RASTER_CULL(Q0, Q1, Z) depth_tiles_behind(Q0, Q1, Z)
#endif

void visit(ivec2 q, float z, float cov) {
    if (!(z >= 0.0 && z < 1.0)) return;
    if (z >= texelFetch(u_scene_depth, q, 0).r) return;
    uint p = oit_pixel_index(q);
    uint zb = floatBitsToUint(z);
#if OIT_CM == 1
    uint idx = atomicAdd(counter[0], 1u);
    if (idx >= u_oit_capacity) return;   // the pool is full: counted, not stored
    uint prev = atomicExchange(heads[p], idx);
    nodes[3u * idx] = zb;
    nodes[3u * idx + 1u] = g_id;
    nodes[3u * idx + 2u] = prev;
#elif OIT_CM == 2
#if OIT_ATOMIC64 || OIT_PASS == 0
    insert_key(zb, q, p, cov);
#else
    claim_slot(zb, q, p, cov);
#endif
#elif OIT_CM == 3
#if OIT_PASS == 0
    if (front[p] > zb) atomicMin(front[p], zb);
#else
    float z0 = oit_view_depth(uintBitsToFloat(front[p]));
    bool inside = oit_view_depth(z) <= z0 + u_oit_shift;
#if OIT_ATOMIC64
    if (inside) {
        insert_key(zb, q, p, cov);
    } else {
        uint64_t key = (uint64_t(zb) << 32) | uint64_t(g_id);
        if (behind[p] > key) atomicMin(behind[p], key);
        atomicAdd(behind_optical[p], oit_optical_units(oit_alpha_of(cov)));
    }
#elif OIT_PASS == 1
    if (inside) {
        insert_key(zb, q, p, cov);
    } else {
        if (behind[p] > zb) atomicMin(behind[p], zb);
        atomicAdd(behind_optical[p], oit_optical_units(oit_alpha_of(cov)));
    }
#else
    if (inside) claim_slot(zb, q, p, cov);
    else if (behind[p] == zb) atomicMax(behind[oit_num_pixels() + p], g_id + 1u);
#endif
#endif
#elif OIT_CM == 4
#if OIT_ATOMIC64 || OIT_PASS == 0
    insert_key(zb, q, p, cov);
    atomicAdd(tail[p], oit_optical_units(oit_alpha_of(cov)));
#else
    claim_slot(zb, q, p, cov);
#endif
#elif OIT_CM == 9
#if OIT_PASS == 0
    atomicAdd(counter[0], 1u);
#else
    uint idx = atomicAdd(counter[1], 1u);
    if (idx >= u_oit_capacity) return;
    vec4 c = oit_shade(g_id, q);
    uint b = 8u * idx;
    records[b] = p;
    records[b + 1u] = zb;
    records[b + 2u] = g_id;
    records[b + 3u] = floatBitsToUint(c.a);
    records[b + 4u] = floatBitsToUint(c.r);
    records[b + 5u] = floatBitsToUint(c.g);
    records[b + 6u] = floatBitsToUint(c.b);
    records[b + 7u] = floatBitsToUint(oit_view_depth(z));
#endif
#endif
}
#define RASTER_VISIT(Q, Z, COV) visit(Q, Z, COV)
#define RASTER_SEGMENT(I) g_id = uint(I)
#include "passes/raster_segment.glsl"

void main() {
    raster_expanded_segment();
}
