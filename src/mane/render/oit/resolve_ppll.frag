#version 430
// Resolve of the per-pixel linked lists (A-buffer; DBK-buffer over its opaque layer): the
// OIT_K nearest fragments sorted (insertion into a local array; ties by node index), the rest
// of the list blended unsorted behind them; OIT_K 0: every fragment, in order, by repeated
// selection of the next nearest (exact, O(n^2)). Output: (premultiplied colour, 1 - T),
// blended ONE, ONE_MINUS_SRC_ALPHA over the HDR target.
// llvmpipe (Mesa) mis-runs a data-dependent loop nested in, or following, another one when
// the SIMD lanes diverge: every loop here is either the one flat walk of the list or has a
// fixed trip count.
// DBK (OIT_METHOD 5): also measures, per pixel, how deep behind the front the layer must reach
// to hold u_oit_k_target fragments, into a histogram (counter[8..]), and the alphas' sum.
#include "oit_common.glsl"

layout(binding = IMG_OIT_HEADS, r32ui) uniform readonly uimage2D u_oit_heads;
layout(std430, binding = B_PPLL_NODES) readonly buffer OitNodes { uvec4 oit_nodes[]; };
layout(std430, binding = B_PPLL_COUNTER) buffer OitCounter { uint oit_counter[]; };
uniform uint u_oit_max_steps;    // guard against a corrupt list
#if OIT_METHOD == 5
layout(binding = IMG_OIT_FRONT, r32ui) uniform readonly uimage2D u_oit_front;
uniform float u_oit_shift;
uniform int u_oit_k_target;      // fragments the layer should hold
uniform float u_oit_hist_max;    // depth (m) of the histogram's last bin
#define OIT_HIST_BINS 64
#define OIT_HIST_FIRST 8
#endif
#ifndef OIT_MEASURE_ONLY
#define OIT_MEASURE_ONLY 0
#endif

layout(location = 0) out vec4 frag;

bool oit_before(float d, uint i, float e, uint j) { return d < e || (d == e && i < j); }

void main() {
    ivec2 xy = ivec2(gl_FragCoord.xy);
    uint head = imageLoad(u_oit_heads, xy).r;
    // (an empty list blends nothing: no early discard)
    vec3 C = vec3(0.0);
    float T = 1.0;
    uint count = 0u;
    float d_last = 0.0;          // depth of the last sorted fragment
    float d_k = -1.0;            // DBK: depth of the u_oit_k_target-th nearest (when sorted)
    uint n_sorted = 0u;
    float asum = 0.0;            // DBK: the alphas of the list
#if OIT_METHOD == 5
    uint k_target = uint(u_oit_k_target);
#else
    uint k_target = 0u;
#endif
    bool tail = false;
#if OIT_K > 0
    float kd[OIT_K];
    uint ki[OIT_K];
    uvec2 kc[OIT_K];
    int n = 0;
    vec3 tC = vec3(0.0);
    float tT = 1.0;
    // One walk of the list; each fragment is inserted into the sorted K by a fixed-length
    // compare-and-shift (unrolled: the arrays stay in registers); the one that falls out of
    // the K (the new one or the farthest kept) is blended into the tail.
    for (int i = 0; i < OIT_K; ++i) {
        kd[i] = 3.0e38;
        ki[i] = OIT_END;
        kc[i] = uvec2(0u);
    }
    for (uint node = head; node != OIT_END && count < u_oit_max_steps; ++count) {
        uvec4 e = oit_nodes[node];
        float d = uintBitsToFloat(e.z);
        uint id = node;
        uvec2 c = e.xy;
        node = e.w;
#if OIT_METHOD == 5
        asum += oit_unpack(c).a;
#endif
        if (!oit_before(d, id, kd[OIT_K - 1], ki[OIT_K - 1])) {
            tail = true;
            oit_blend(tC, tT, oit_unpack(c));
            continue;
        }
        if (ki[OIT_K - 1] != OIT_END) {
            tail = true;
            oit_blend(tC, tT, oit_unpack(kc[OIT_K - 1]));   // the farthest kept goes to the tail
        }
        for (int j = OIT_K - 1; j > 0; --j) {
            if (oit_before(d, id, kd[j - 1], ki[j - 1])) {
                kd[j] = kd[j - 1];
                ki[j] = ki[j - 1];
                kc[j] = kc[j - 1];
            } else if (oit_before(d, id, kd[j], ki[j])) {
                kd[j] = d;
                ki[j] = id;
                kc[j] = c;
            }
        }
        if (oit_before(d, id, kd[0], ki[0])) {
            kd[0] = d;
            ki[0] = id;
            kc[0] = c;
        }
        n = min(n + 1, OIT_K);
    }
    for (int i = 0; i < OIT_K; ++i) {      // fixed trip count (llvmpipe, see above)
        if (i < n) {
            oit_blend(C, T, oit_unpack(kc[i]));
            d_last = kd[i];
            ++n_sorted;
            if (n_sorted == k_target) d_k = kd[i];
        }
    }
    C += T * tC;
    T *= tT;
#else
    // One flat loop (walk the list, blend the nearest not yet blended, walk again): llvmpipe
    // mis-runs nested data-dependent loops whose lanes diverge.
    float last_d = -3.0e38;
    uint last_i = 0u;
    float bd = 3.0e38;
    uint bi = OIT_END;
    uvec2 bc = uvec2(0u);
    uint node = head;
    bool more = head != OIT_END;
    uint limit = u_oit_max_steps * 64u;
    for (uint step = 0u; more && step < limit; ++step) {
        if (node != OIT_END) {
            uvec4 e = oit_nodes[node];
            float d = uintBitsToFloat(e.z);
            if (oit_before(last_d, last_i, d, node) && oit_before(d, node, bd, bi)) {
                bd = d;
                bi = node;
                bc = e.xy;
            }
            node = e.w;
        } else if (bi == OIT_END) {
            more = false;                       // every fragment blended
        } else {
            oit_blend(C, T, oit_unpack(bc));
            ++count;
            d_last = bd;
            ++n_sorted;
            asum += oit_unpack(bc).a;
            if (n_sorted == k_target) d_k = bd;
            last_d = bd;
            last_i = bi;
            bd = 3.0e38;
            bi = OIT_END;
            node = head;
            more = !(T < 1e-7 && k_target == 0u);
        }
    }
#endif
    if (count > 0u) atomicMax(oit_counter[1], count);
#if OIT_METHOD == 5
    // the depth behind the front this pixel needs to keep k_target fragments (Python picks
    // k_target from the measured alpha: (1 - alpha)^k < threshold). Pixels with fewer
    // fragments and none behind the layer keep all of theirs anyway; sparse ones with hair far
    // behind (a gap) are left out; a dense one whose layer was too thin extrapolates.
    uint f = imageLoad(u_oit_front, xy).r;
    float z0 = uintBitsToFloat(f & ~OIT_BEHIND);
    bool behind = (f & OIT_BEHIND) != 0u;
    float need = -1.0;
    if (count >= k_target) {
        need = d_k >= 0.0 ? d_k - z0 : (d_last - z0) * float(k_target) / float(max(n_sorted, 1u));
    } else if (behind && 2u * count >= k_target) {
        need = u_oit_shift * float(k_target) / float(max(count, 1u));
    }
    if (count > 0u) {
        atomicAdd(oit_counter[2], count);
        atomicAdd(oit_counter[3], 1u);
        atomicAdd(oit_counter[4], uint(asum * 64.0 + 0.5));
    }
    if (need >= 0.0) {
        int bin = clamp(int(need / u_oit_hist_max * float(OIT_HIST_BINS)), 0, OIT_HIST_BINS - 1);
        atomicAdd(oit_counter[OIT_HIST_FIRST + bin], 1u);
        atomicAdd(oit_counter[5], 1u);
    }
#endif
#if OIT_MEASURE_ONLY
    discard;
#else
    frag = vec4(C, 1.0 - T);
#endif
}
