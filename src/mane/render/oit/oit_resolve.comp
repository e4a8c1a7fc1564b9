#version 430
// The compute OIT methods' resolve (oit/compute.py), one thread per pixel: the kept fragments
// (oit_raster.comp) shaded at the pixel (compute_oit.glsl), blended front to back over what is
// there (the head and background, premultiplied HDR: imageLoad / imageStore), the per-pixel
// storage reset for the next frame on the way (u_reset).
//   1 A-buffer:   the list walked once; the OIT_K nearest kept sorted (insertion, ties by
//                 segment), the others blended unsorted behind them; OIT_K 0: every fragment in
//                 order (repeated selection of the next nearest, exact).
//   2 K-buffer:   the slots in order, then the tail (alpha-weighted mean colour, its product of
//                 transmittances; OIT_TAIL_SHADED 0: the farthest kept fragment's colour).
//   3 DBK-buffer: as the K-buffer over the hair behind the layer (the colour of its nearest
//                 fragment with the opacity of all of it, or that fragment opaque:
//                 OIT_DBK_BEHIND_OPAQUE); measures what the automatic shift needs (as
//                 resolve_ppll.frag: counter words 0..5, histogram from word 8; per work group in
//                 shared memory, then into one of MEASURE_COPIES copies).
//   4 ShortCut:   the 3 nearest's alpha-weighted mean colour with every fragment's opacity.
// Loops have fixed trip counts except the one walk of a list (llvmpipe, see resolve_ppll.frag).
#if OIT_ATOMIC64
#extension GL_ARB_gpu_shader_int64 : require
#endif
#ifndef RESOLVE_GROUP
#define RESOLVE_GROUP 16
#endif
layout(local_size_x = RESOLVE_GROUP, local_size_y = RESOLVE_GROUP) in;
#include "shading/hair_shading.glsl"
#include "passes/hair_radiance.glsl"
#include "compute_oit.glsl"
#include "oit_common.glsl"

layout(rgba16f, binding = IMG_HDR) uniform image2D u_hdr;
uniform int u_reset;               // 1: leave the storage empty for the next frame
uniform uint u_oit_max_steps;      // A-buffer: guard against a corrupt list
#ifndef OIT_MEASURE_ONLY
#define OIT_MEASURE_ONLY 0
#endif

#if OIT_CM == 1
layout(std430, binding = B_OIT_HEADS) buffer Heads { uint heads[]; };
layout(std430, binding = B_OIT_NODES) readonly buffer Nodes { uint nodes[]; };
layout(std430, binding = B_OIT_COUNTER) buffer Counter { uint counter[]; };
#else
#if OIT_ATOMIC64
layout(std430, binding = B_OIT_SLOTS) buffer Slots { uint64_t slots[]; };
#else
layout(std430, binding = B_OIT_SLOTS) buffer Slots { uint slots[]; };
layout(std430, binding = B_OIT_SLOT_IDS) buffer SlotIds { uint slot_ids[]; };
#endif
layout(std430, binding = B_OIT_TAIL) buffer Tail { uint tail[]; };
#endif
#if OIT_CM == 3
layout(std430, binding = B_OIT_FRONT) buffer Front { uint front[]; };
#if OIT_ATOMIC64
layout(std430, binding = B_OIT_BEHIND) buffer Behind { uint64_t behind[]; };
#else
layout(std430, binding = B_OIT_BEHIND) buffer Behind { uint behind[]; };
#endif
layout(std430, binding = B_OIT_BEHIND_OPTICAL) buffer BehindOptical { uint behind_optical[]; };
// MEASURE_COPIES copies of the counters, MEASURE_STRIDE words apart, summed by Python (word 1:
// the largest): a work group adds its pixels' sums up in shared memory first, then into the
// copy of its index, so that no global word takes one atomic per pixel.
layout(std430, binding = B_OIT_MEASURE) buffer Measure { uint measure[]; };
uniform float u_oit_shift;
uniform int u_oit_k_target;      // fragments the layer should hold
uniform float u_oit_hist_max;    // depth (m) of the histogram's last bin
#define OIT_HIST_BINS 64
#define OIT_HIST_FIRST 8
#define MEASURE_WORDS 72u
#ifndef MEASURE_COPIES
#define MEASURE_COPIES 16
#define MEASURE_STRIDE 80
#endif
shared uint s_measure[MEASURE_WORDS];
#elif OIT_CM == 1
shared uint s_max_list;
#endif

bool key_before(uint z, uint i, uint y, uint j) { return z < y || (z == y && i < j); }

void resolve_pixel(ivec2 q) {
    uint P = oit_num_pixels();
    uint p = oit_pixel_index(q);
    vec3 C = vec3(0.0);
    float T = 1.0;

#if OIT_CM == 1
    uint head = heads[p];
    uint count = 0u;
#if OIT_K > 0
    uint kz[OIT_K];
    uint ks[OIT_K];
    for (int i = 0; i < OIT_K; ++i) {
        kz[i] = OIT_EMPTY;
        ks[i] = OIT_EMPTY;
    }
    int n = 0;
    vec3 tC = vec3(0.0);
    float tT = 1.0;
    for (uint node = head; node != OIT_EMPTY && count < u_oit_max_steps; ++count) {
        uint z = nodes[3u * node];
        uint id = nodes[3u * node + 1u];
        node = nodes[3u * node + 2u];
        if (!key_before(z, id, kz[OIT_K - 1], ks[OIT_K - 1])) {
            oit_blend(tC, tT, oit_shade(id, q));
            continue;
        }
        if (ks[OIT_K - 1] != OIT_EMPTY)
            oit_blend(tC, tT, oit_shade(ks[OIT_K - 1], q));   // the farthest kept goes to the tail
        for (int j = OIT_K - 1; j > 0; --j) {
            if (key_before(z, id, kz[j - 1], ks[j - 1])) {
                kz[j] = kz[j - 1];
                ks[j] = ks[j - 1];
            } else if (key_before(z, id, kz[j], ks[j])) {
                kz[j] = z;
                ks[j] = id;
            }
        }
        if (key_before(z, id, kz[0], ks[0])) {
            kz[0] = z;
            ks[0] = id;
        }
        n = min(n + 1, OIT_K);
    }
    for (int i = 0; i < OIT_K; ++i)
        if (i < n) oit_blend(C, T, oit_shade(ks[i], q));
    C += T * tC;
    T *= tT;
#else
    // one flat loop: walk the list for the nearest after the last blended, blend it, walk again
    bool started = false;
    uint last_z = 0u, last_i = 0u;
    uint bz = OIT_EMPTY, bi = OIT_EMPTY;
    uint node = head;
    bool more = head != OIT_EMPTY;
    uint limit = u_oit_max_steps * 64u;
    for (uint step = 0u; more && step < limit; ++step) {
        if (node != OIT_EMPTY) {
            uint z = nodes[3u * node];
            uint id = nodes[3u * node + 1u];
            if ((!started || key_before(last_z, last_i, z, id)) && key_before(z, id, bz, bi)) {
                bz = z;
                bi = id;
            }
            node = nodes[3u * node + 2u];
        } else if (bi == OIT_EMPTY) {
            more = false;                       // every fragment blended
        } else {
            oit_blend(C, T, oit_shade(bi, q));
            ++count;
            started = true;
            last_z = bz;
            last_i = bi;
            bz = OIT_EMPTY;
            bi = OIT_EMPTY;
            node = head;
            more = !(T < 1e-7);
        }
    }
#endif
    if (count > 0u) atomicMax(s_max_list, count);
    if (u_reset != 0) heads[p] = OIT_EMPTY;

#else   // slots: K-buffer, DBK-buffer, ShortCut
    uint base = p * uint(OIT_K);
    uint n = 0u;
    float asum = 0.0;
    float d_last = 0.0;
    float d_k = -1.0;
#if OIT_CM == 3
    uint k_target = uint(u_oit_k_target);
#else
    uint k_target = 0u;
#endif
    vec4 acc = vec4(0.0);
    vec3 last_rgb = vec3(0.0);     // the farthest kept fragment's colour (unpremultiplied)
    bool done = false;
    for (int i = 0; i < OIT_K; ++i) {      // ascending; the first empty slot ends the kept ones
        if (done) continue;
#if OIT_ATOMIC64
        uint64_t key = slots[base + uint(i)];
        bool valid = key != 0xFFFFFFFFFFFFFFFFul;
        uint seg = uint(key & 0xFFFFFFFFul);
        uint zb = uint(key >> 32);
        if (valid && u_reset != 0) slots[base + uint(i)] = 0xFFFFFFFFFFFFFFFFul;
#else
        uint zb = slots[base + uint(i)];
        uint seg = slot_ids[base + uint(i)];
        bool valid = zb != OIT_EMPTY && seg != OIT_EMPTY;
        if (zb != OIT_EMPTY && u_reset != 0) {
            slots[base + uint(i)] = OIT_EMPTY;
            slot_ids[base + uint(i)] = OIT_EMPTY;
        }
#endif
        if (zb == OIT_EMPTY) { done = true; continue; }
        if (!valid) continue;
        vec4 c = oit_shade(seg, q);
        if (c.a > 1e-6) last_rgb = c.rgb / c.a;
#if OIT_CM == 4
        acc += c;
#else
        oit_blend(C, T, c);
#endif
        ++n;
        asum += c.a;
        float d = oit_view_depth(uintBitsToFloat(zb));
        d_last = d;
        if (n == k_target) d_k = d;
    }
#if OIT_CM == 4
    float Tall = exp(-float(tail[p]) / OIT_SCALE);
    if (u_reset != 0) tail[p] = 0u;
    if (Tall < 1.0 && acc.a > 1e-6) {
        C = acc.rgb / acc.a * (1.0 - Tall);
        T = Tall;
    }
#else
    uint tn = tail[TW_N * P + p];
    if (tn > 0u) {
        float ta = float(tail[TW_A * P + p]) / OIT_SCALE;
        float tT = exp(-float(tail[TW_OPT * P + p]) / OIT_SCALE);
#if OIT_TAIL_SHADED
        // the fragments out of the slots: their alpha-weighted mean colour, all their opacity
        vec3 trgb = vec3(float(tail[TW_R * P + p]), float(tail[TW_G * P + p]), float(tail[TW_B * P + p]))
                    / OIT_SCALE;
        if (ta > 1e-6) {
            C += T * trgb / ta * (1.0 - tT);
            T *= tT;
        }
#else
        // ... with the colour of the farthest kept fragment (the tail lies behind it)
        C += T * last_rgb * (1.0 - tT);
        T *= tT;
#endif
        asum += ta;
        if (u_reset != 0)
            for (uint w = 0u; w < TW_WORDS; ++w) tail[w * P + p] = 0u;
    }
    uint count = n + tn;
#endif

#if OIT_CM == 3
    // the hair behind the layer: its nearest fragment's colour with the opacity of all of it
    // (1 - prod(1 - alpha)), or opaque
    uint f = front[p];
#if OIT_ATOMIC64
    uint64_t bk = behind[p];
    bool has_behind = bk != 0xFFFFFFFFFFFFFFFFul;
    uint bseg = uint(bk & 0xFFFFFFFFul);
#else
    uint bid = behind[P + p];
    bool has_behind = bid != 0u;
    uint bseg = bid - 1u;
#endif
    if (has_behind) {
        vec4 c = oit_shade(bseg, q);
        vec3 rgb = c.rgb / max(c.a, 1e-6);
#if OIT_DBK_BEHIND_OPAQUE
        if (c.a > 0.0) {                                        // Hunz: opaque
            C += T * rgb;
            T = 0.0;
        }
#else
        float Tb = exp(-float(behind_optical[p]) / OIT_SCALE);
        C += T * rgb * (1.0 - Tb);
        T *= Tb;
#endif
    }
    if (u_reset != 0 && f != OIT_EMPTY) {
        behind_optical[p] = 0u;
        front[p] = OIT_EMPTY;
#if OIT_ATOMIC64
        behind[p] = 0xFFFFFFFFFFFFFFFFul;
#else
        behind[p] = OIT_EMPTY;
        behind[P + p] = 0u;
#endif
    }
    // the depth behind the front this pixel needs to keep k_target fragments (resolve_ppll.frag)
    float z0 = oit_view_depth(uintBitsToFloat(f));
    float need = -1.0;
    if (count >= k_target) {
        need = d_k >= 0.0 ? d_k - z0 : (d_last - z0) * float(k_target) / float(max(n, 1u));
    } else if (has_behind && 2u * count >= k_target) {
        need = u_oit_shift * float(k_target) / float(max(count, 1u));
    }
    if (count > 0u) {
        atomicAdd(s_measure[0], count);
        atomicMax(s_measure[1], count);
        atomicAdd(s_measure[2], count);
        atomicAdd(s_measure[3], 1u);
        atomicAdd(s_measure[4], uint(asum * 64.0 + 0.5));
    }
    if (need >= 0.0 && f != OIT_EMPTY) {
        int bin = clamp(int(need / u_oit_hist_max * float(OIT_HIST_BINS)), 0, OIT_HIST_BINS - 1);
        atomicAdd(s_measure[OIT_HIST_FIRST + bin], 1u);
        atomicAdd(s_measure[5], 1u);
    }
#endif
#endif

#if !OIT_MEASURE_ONLY
    if (T < 1.0) {
        vec4 bg = imageLoad(u_hdr, q);
        imageStore(u_hdr, q, vec4(C, 1.0 - T) + T * bg);
    }
#endif
}

void main() {
    uint li = gl_LocalInvocationIndex;
    uint group = gl_WorkGroupSize.x * gl_WorkGroupSize.y;
#if OIT_CM == 3
    for (uint w = li; w < MEASURE_WORDS; w += group) s_measure[w] = 0u;
#elif OIT_CM == 1
    if (li == 0u) s_max_list = 0u;
#endif
    memoryBarrierShared();
    barrier();
    ivec2 q = ivec2(gl_GlobalInvocationID.xy);
    if (q.x < u_raster_size.x && q.y < u_raster_size.y) resolve_pixel(q);
    memoryBarrierShared();
    barrier();
#if OIT_CM == 3
    uint copy = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) % uint(MEASURE_COPIES);
    for (uint w = li; w < MEASURE_WORDS; w += group) {
        uint v = s_measure[w];
        if (v == 0u) continue;
        if (w == 1u) atomicMax(measure[copy * uint(MEASURE_STRIDE) + w], v);
        else atomicAdd(measure[copy * uint(MEASURE_STRIDE) + w], v);
    }
#elif OIT_CM == 1
    if (li == 0u && s_max_list > counter[1]) atomicMax(counter[1], s_max_list);
#endif
}
