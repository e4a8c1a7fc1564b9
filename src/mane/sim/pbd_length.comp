#version 430 core
// PBD distance constraints, solved in parallel: SPG strands per work group, one thread
// per particle, positions in shared memory. Each iteration projects the segments that
// start at even k, then those at odd k (Gauss-Seidel by colour), each with
//   C = |p_a - p_b| - l,  dp_a = -w_a / (w_a + w_b) C n,  dp_b = +w_b / (w_a + w_b) C n
// and, with long-range attachment, clamps every particle to within its rest arc length
// of the root (a unilateral tether); then, with colliders (PRIMS, NSDF: contact.glsl),
// projects every free particle out of them, with friction. The iterations end with that
// projection, so no particle is left inside; the next iteration's distance constraints
// pull the strand back toward its lengths around the colliders.
#include "sim_common.glsl"
#include "collide.glsl"
#include "contact.glsl"

// SPG (strands per group) and GROUP_SIZE = NV * SPG are injected by the simulator
// (GLSL 4.30 takes no expressions in layout qualifiers).
layout(local_size_x = GROUP_SIZE) in;

uniform int iterations;
uniform int tether;

shared vec4 sp[GROUP_SIZE];

void project(uint a, uint b, float l) {
    vec4 pa = sp[a], pb = sp[b];
    float wsum = pa.w + pb.w;
    vec3 d = pb.xyz - pa.xyz;
    float len = length(d);
    if (wsum <= 0.0 || !(len > 1e-12)) return;
    vec3 corr = ((len - l) / (wsum * len)) * d;
    sp[a].xyz = pa.xyz + pa.w * corr;
    sp[b].xyz = pb.xyz - pb.w * corr;
}

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint ls = lid / uint(NV);
    uint k = lid - ls * uint(NV);
    uint s = gl_WorkGroupID.x * uint(SPG) + ls;
    bool live = s < num_strands;
    uint i = s * uint(NV) + k;
    uint root = ls * uint(NV);
    float l_next = 0.0, arc = 0.0;
#if PRIMS > 0 || NSDF > 0
    vec3 x0 = vec3(0.0);
    if (live) x0 = prev_positions[i].xyz;
#endif
    if (live) {
        sp[lid] = vec4(positions[i].xyz, rest_positions[i].w);
        if (k + 1u < uint(NV)) l_next = rest_info[i + 1u].x;
        arc = rest_info[i].y;
    }
    barrier();
    for (int it = 0; it < iterations; ++it) {
        if (live && (k & 1u) == 0u && k + 1u < uint(NV)) project(lid, lid + 1u, l_next);
        memoryBarrierShared();
        barrier();
        if (live && (k & 1u) == 1u && k + 1u < uint(NV)) project(lid, lid + 1u, l_next);
        memoryBarrierShared();
        barrier();
        if (tether != 0) {
            if (live && k > 0u && sp[lid].w > 0.0) {
                vec3 r = sp[root].xyz;
                vec3 d = sp[lid].xyz - r;
                float len = length(d);
                if (len > arc && len > 1e-12) sp[lid].xyz = r + d * (arc / len);
            }
            memoryBarrierShared();
            barrier();
        }
#if PRIMS > 0 || NSDF > 0
        if (live && sp[lid].w > 0.0) {
            vec3 p = sp[lid].xyz, n;
            if (project_out(p, x0, n)) sp[lid].xyz = p;
        }
        memoryBarrierShared();
        barrier();
#endif
    }
    if (live) positions[i] = vec4(sp[lid].xyz, positions[i].w);
}
