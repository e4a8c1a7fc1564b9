#version 430
// pipeline="compute": every rendered strand's tessellated points, once per frame (or when the
// guides change), shared by every pass that draws the hair (hair_pull.vert pulls them).
// Point j of strand r: guide segment seg = j / u_subdivisions, u = (j mod u_subdivisions) /
// u_subdivisions, the last point the tip (u = 1 of the last segment); strand_eval.glsl is
// the tessellation evaluation stage's own code. No distance LOD here (the renderer draws LOD
// through the tessellation pipeline).
layout(local_size_x = 128) in;
#include "strand_common.glsl"
#include "strand_eval.glsl"

// 2 vec4 per point: (position, width), (unit tangent, strand random)
layout(std430, binding = 3) writeonly buffer Expanded { vec4 expanded[]; };
uniform int u_num_strands;     // rendered strands

void main() {
    int points = (u_n - 1) * u_subdivisions + 1;
    int idx = int((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
                  + gl_LocalInvocationID.x);
    if (idx >= u_num_strands * points) return;
    int r = idx / points;
    int j = idx - r * points;
    int seg = min(j / u_subdivisions, u_n - 2);
    float u = float(j - seg * u_subdivisions) / float(u_subdivisions);
#if MULTI
    vec3 z = vec3(0.0);
    StrandVertex v = strand_eval(r / 64, seg, u, r, float(u_strands_per_guide), 0.0, z, z, z, z, z, z);
#else
    int guide = r / u_strands_per_guide;
    int strand = r - guide * u_strands_per_guide;
    StrandVertex v = strand_eval(guide, seg, u, strand, float(u_strands_per_guide), 0.0,
                                 guide_point(guide, seg - 1), guide_point(guide, seg),
                                 guide_point(guide, seg + 1), guide_point(guide, seg + 2),
                                 guide_normal(guide, seg), guide_normal(guide, seg + 1));
#endif
    expanded[2 * idx] = vec4(v.pos, v.width);
    expanded[2 * idx + 1] = vec4(v.tangent, v.rand);
}
