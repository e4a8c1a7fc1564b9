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
layout(local_size_x = 128) in;
#include "strand_common.glsl"
#include "strand_eval.glsl"

// 2 vec4 per point: (position, width), (unit tangent, strand random)
layout(std430, binding = B_EXPANDED) writeonly buffer Expanded { vec4 expanded[]; };
uniform int u_num_strands;     // rendered strands

void main() {
    int points = (u_n - 1) * u_subdivisions + 1;
    int idx = int((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
                  + gl_LocalInvocationID.x);
    if (idx >= u_num_strands * points) return;
    int r = idx / points;
    int j = idx - r * points;
    int seg = min(j / u_subdivisions, u_n - 2);
    int k = j - seg * u_subdivisions;
    float u = float(k) / float(u_subdivisions);
#if MULTI
    vec3 root = guide_point(strand_table[min(r, u_num_render - 1)].guides.x, 0);
#else
    int guide = r / u_strands_per_guide;
    int strand = r - guide * u_strands_per_guide;
    vec3 root = guide_point(guide, 0);
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
    StrandVertex v = strand_eval(r / 64, seg, u, r, lod_count, lod_tp, z, z, z, z, z, z);
#else
    StrandVertex v = strand_eval(guide, seg, u, strand, lod_count, lod_tp,
                                 guide_point(guide, seg - 1), guide_point(guide, seg),
                                 guide_point(guide, seg + 1), guide_point(guide, seg + 2),
                                 guide_normal(guide, seg), guide_normal(guide, seg + 1));
#endif
    expanded[2 * idx] = vec4(v.pos, v.width * v.lod_alpha);
    expanded[2 * idx + 1] = vec4(v.tangent, v.rand);
}
