#version 430 core
// PBD distance constraints that converge: XPBD (Macklin et al. 2016) with each iteration a
// direct solve of the whole strand's constraint chain (Goldenthal et al. 2007's fast
// projection; Deul et al. 2018's direct position-based solver), then one odd/even sweep of
// exact pairwise projections. SPG strands per work group, one thread per particle,
// positions in shared memory. One iteration:
//
// 1. with colliders (PRIMS, NSDF: contact.glsl), every free particle is projected out of
//    them, with friction, unless its root lies deeper inside than the particle's rest arc
//    length (then no position is both outside and at its lengths: the lengths win, as in DFTL);
// 2. segment j joins particles j and j+1: C_j = |p_{j+1} - p_j| - l_j, n_j its unit direction,
//    w inverse masses (0 at the pinned root: infinite mass). Solve
//      (J W J^T + alpha~ I) dlambda = -(C + alpha~ lambda),    alpha~ = compliance / dt^2,
//    a symmetric tridiagonal system (diagonal (w_j + w_{j+1}) + alpha~, off-diagonal
//    -w_{j+1} n_j . n_{j+1}): every thread builds its segment's row, the strand's first
//    thread runs the Thomas algorithm, every particle moves by
//      dp_i = w_i (n_{i-1} dlambda_{i-1} - n_i dlambda_i),    lambda += dlambda;
//    Newton's method on the constraints: quadratic convergence near the solution, and the
//    stiffness is set by the compliance alone (0: inextensible), not by the iteration count;
// 3. the segments from even k, then from odd k, are projected exactly (Gauss-Seidel by
//    colour, each pair mass-weighted: dp_a = w_a / (w_a + w_b) C n, dp_b = -w_b / (..) C n;
//    only with compliance 0), which takes out what the linearisation leaves when a step
//    moves particles by more than a segment;
// 4. with long-range attachment, every particle is clamped to within its rest arc length of
//    the root (a unilateral tether).
#include "sim_common.glsl"
#include "collide.glsl"
#include "contact.glsl"

// SPG (strands per group) and GROUP_SIZE = NV * SPG are injected by the simulator
// (GLSL 4.30 takes no expressions in layout qualifiers).
layout(local_size_x = GROUP_SIZE) in;

uniform int iterations;
uniform int tether;
uniform float alpha_tilde;   // compliance / dt^2

shared vec4 sp[GROUP_SIZE];     // position, inverse mass
shared vec4 sn[GROUP_SIZE];     // n_j (segment from this particle), C_j
shared vec2 sm[GROUP_SIZE];     // row j: (diagonal, super-diagonal) -> (.., c')
shared float sr[GROUP_SIZE];    // row j: right-hand side -> dlambda_j

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
    bool seg = k + 1u < uint(NV);   // this thread owns segment k (k -> k+1)
    float l_next = 0.0, arc = 0.0, lambda = 0.0;
#if PRIMS > 0 || NSDF > 0
    vec3 x0 = vec3(0.0);
    if (live) x0 = prev_positions[i].xyz;
#endif
    if (live) {
        sp[lid] = vec4(positions[i].xyz, rest_positions[i].w);
        if (seg) l_next = rest_info[i + 1u].x;
        arc = rest_info[i].y;
    }
    barrier();
    for (int it = 0; it < iterations; ++it) {
#if PRIMS > 0 || NSDF > 0
        if (live && sp[lid].w > 0.0) {
            // out of the colliders, unless the root is buried deeper than this particle's arc
            // length (nothing outside is within its reach: the lengths win, as in DFTL)
            vec3 p = sp[lid].xyz, n;
            if (project_out(p, x0, n)) {
                vec3 r = sp[root].xyz, rn;
                vec3 r0 = r;
                project_out(r, r0, rn);
                if (distance(r, r0) <= arc) sp[lid].xyz = p;
            }
        }
        memoryBarrierShared();
        barrier();
#endif
        // this segment's constraint and direction
        if (live && seg) {
            vec3 d = sp[lid + 1u].xyz - sp[lid].xyz;
            float len = length(d);
            vec3 n = len > 1e-12 ? d / len : vec3(0.0);
            sn[lid] = vec4(n, len - l_next);
        }
        memoryBarrierShared();
        barrier();
        // its row of the system
        if (live && seg) {
            vec3 n = sn[lid].xyz;
            float wa = sp[lid].w, wb = sp[lid + 1u].w;
            float diag = (wa + wb) * dot(n, n) + alpha_tilde;
            float off = k + 2u < uint(NV) ? -wb * dot(n, sn[lid + 1u].xyz) : 0.0;
            float rhs = -(sn[lid].w + alpha_tilde * lambda);
            if (!(diag > 0.0)) { diag = 1.0; rhs = 0.0; off = 0.0; }   // both ends pinned: no change
            sm[lid] = vec2(diag, off);
            sr[lid] = rhs;
        }
        memoryBarrierShared();
        barrier();
        // Thomas: forward elimination, back substitution (the strand's first thread)
        if (live && k == 0u) {
            uint last = root + uint(NV) - 2u;
            float cp = sm[root].y / sm[root].x;
            float dp = sr[root] / sm[root].x;
            sm[root].y = cp;
            sr[root] = dp;
            for (uint j = root + 1u; j <= last; ++j) {
                float a = -sp[j].w * dot(sn[j - 1u].xyz, sn[j].xyz);   // A_{j,j-1} = A_{j-1,j}
                float m = sm[j].x - a * cp;
                cp = sm[j].y / m;
                dp = (sr[j] - a * dp) / m;
                sm[j].y = cp;
                sr[j] = dp;
            }
            for (uint j = last; j > root; --j) sr[j - 1u] -= sm[j - 1u].y * sr[j];
        }
        memoryBarrierShared();
        barrier();
        // every particle moves by its rows' impulses
        if (live) {
            float dl_prev = k > 0u ? sr[lid - 1u] : 0.0;
            float dl = seg ? sr[lid] : 0.0;
            vec3 n_prev = k > 0u ? sn[lid - 1u].xyz : vec3(0.0);
            vec3 n = seg ? sn[lid].xyz : vec3(0.0);
            lambda += dl;
            sp[lid].xyz += sp[lid].w * (n_prev * dl_prev - n * dl);
        }
        memoryBarrierShared();
        barrier();
        if (alpha_tilde == 0.0) {
            if (live && (k & 1u) == 0u && seg) project(lid, lid + 1u, l_next);
            memoryBarrierShared();
            barrier();
            if (live && (k & 1u) == 1u && seg) project(lid, lid + 1u, l_next);
            memoryBarrierShared();
            barrier();
        }
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
    }
    if (live) positions[i] = vec4(sp[lid].xyz, positions[i].w);
}
