#version 430
// pipeline="compute": every rendered strand's tessellated points, once per frame (or when the
// guides change), shared by every pass that draws the hair (hair_pull.vert pulls them).
// Point j of strand r: guide segment seg = j / u_subdivisions, u = (j mod u_subdivisions) /
// u_subdivisions, the last point the tip (u = 1 of the last segment); strand_eval.glsl is
// the tessellation evaluation stage's own code. Distance LOD (LOD 1): a guide segment keeps
// L = clamp(wanted / guide segments, 1, u_subdivisions) segments, wanted as the tessellation
// control stage computes it (hair.tesc), its points at u = min(k / L, 1) (floor(L) equal
// segments, a shorter last one, the rest of the points at the segment's end: zero-length
// segments the rasterisers skip), so the curve changes continuously with the distance; a
// strand fading out (its LOD alpha) has its width scaled by that alpha, 0: not drawn.
// Coverage LOD (mane.render.coverage_lod): only the first u_kept_per_guide strands of each
// guide are expanded, widened by u_width_scale. Instances: one dispatch per instance, its
// strands from u_first_strand on, moved by its rigid transform u_model.
// The shading tangent is the direction of the point's neighbours on the strand (strand_eval.glsl,
// strand_curve_tangent): a work group of EXPAND_LOCAL invocations writes EXPAND_POINTS (its size
// less 2) consecutive points, its first and last invocations evaluating the points on either
// side of them, and each reads its neighbours from shared memory (expand.py's LOCAL_SIZE and
// EXPAND_POINTS).
layout(local_size_x = EXPAND_LOCAL) in;
shared vec3 s_pos[EXPAND_LOCAL];
#include "strand_common.glsl"
#include "strand_eval.glsl"

// 2 vec4 per point: (position, width), (unit tangent, strand random)
layout(std430, binding = B_EXPANDED) writeonly buffer Expanded { vec4 expanded[]; };
uniform int u_num_strands;     // rendered strands of this dispatch
uniform int u_kept_per_guide;  // single: strands of each guide expanded (<= u_strands_per_guide)
uniform float u_width_scale;   // u_strands_per_guide / u_kept_per_guide: the dropped strands' width
uniform int u_first_strand;    // this dispatch's first strand in the buffer
uniform mat4 u_model;          // the instance's local -> world (rigid)
uniform int u_level;           // segments of a guide segment this instance uses (<= u_subdivisions):
                               // its points past them sit at the segment's end (zero length)

void main() {
    int points = (u_n - 1) * u_subdivisions + 1;
    int local = int(gl_LocalInvocationID.x);
    int idx = int(gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * EXPAND_POINTS + local - 1;
    bool valid = idx >= 0 && idx < u_num_strands * points;
    int j = 0;
    StrandVertex v;
    if (valid) {
        int r = idx / points;
        j = idx - r * points;
        int seg = min(j / u_subdivisions, u_n - 2);
        int k = j - seg * u_subdivisions;
        float u = u_level < u_subdivisions ? min(float(k) / float(u_level), 1.0) : float(k) / float(u_subdivisions);
#if MULTI
        vec3 root = guide_point(strand_table[min(r, u_num_render - 1)].guides.x, 0);
#else
        int guide = r / u_kept_per_guide;
        int strand = r - guide * u_kept_per_guide;
        vec3 root = (u_model * vec4(guide_point(guide, 0), 1.0)).xyz;
#endif
        float lod_count = float(u_strands_per_guide), lod_tp = 0.0;
#if LOD
        lod_tp = lod_t(root);
        float wanted = max(u_lod_segments.y, float(u_segments) * mix(1.0, u_lod_segments.x, lod_tp));
        float level = clamp(wanted / float(u_n - 1), 1.0, float(u_subdivisions));
        u = min(float(k) / level, 1.0);
        lod_count = mix(1.0, u_lod_range.z, lod_tp) * float(u_strands_per_guide);
#endif
#if MULTI
        vec3 z = vec3(0.0);
        v = strand_eval(r / 64, seg, u, r, lod_count, lod_tp, z, z, z, z, z, z);
#else
        v = strand_eval(guide, seg, u, strand, lod_count, lod_tp,
                        guide_point(guide, seg - 1), guide_point(guide, seg),
                        guide_point(guide, seg + 1), guide_point(guide, seg + 2),
                        guide_normal(guide, seg), guide_normal(guide, seg + 1));
#endif
        s_pos[local] = v.pos;
    }
    barrier();
    if (!valid || local == 0 || local == EXPAND_LOCAL - 1) return;   // past the end, or a neighbour's point
    vec3 a = j > 0 ? s_pos[local - 1] : v.pos;               // the strand's previous point
    vec3 b = j < points - 1 ? s_pos[local + 1] : v.pos;      // and its next
    vec3 T = strand_tilted(strand_curve_tangent(a, b, v.tangent), v);
    int o = u_first_strand * points + idx;
    expanded[2 * o] = vec4((u_model * vec4(v.pos, 1.0)).xyz, v.width * v.lod_alpha * u_width_scale);
    expanded[2 * o + 1] = vec4(mat3(u_model) * T, v.rand);   // rigid: still unit
}
