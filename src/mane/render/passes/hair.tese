#version 430
// Evaluate the curve, then move the strand off its guide (strand_eval.glsl).
#include "strand_common.glsl"
#include "strand_eval.glsl"
#if LOD
layout(isolines, fractional_odd_spacing) in;
#else
layout(isolines, equal_spacing) in;
#endif

in vec3 c_pos[];
in vec3 c_normal[];
patch in int p_guide;
patch in int p_seg;
patch in int p_first_strand;
patch in float p_lod_count;
patch in float p_lod_t;

out vec3 e_pos;
out vec3 e_tangent;
out float e_s;        // 0 at the root .. 1 at the tip
out float e_rand;     // per strand, in [0,1)
out float e_width;    // metres
out float e_id;       // guide * strands_per_guide + strand (MULTI: the record index)
out float e_lod_alpha;// LOD fade of the strand (1 kept, 0 dropped)

void main() {
    float u = gl_TessCoord.x;
    int line = int(round(gl_TessCoord.y * gl_TessLevelOuter[0]));
    StrandVertex v = strand_eval(p_guide, p_seg, u, p_first_strand + line, p_lod_count, p_lod_t,
                                 c_pos[0], c_pos[1], c_pos[2], c_pos[3], c_normal[1], c_normal[2]);
    e_pos = v.pos;
    e_tangent = v.tangent;
    e_s = v.s;
    e_rand = v.rand;
    e_width = v.width;
    e_id = v.id;
    e_lod_alpha = v.lod_alpha;
}
