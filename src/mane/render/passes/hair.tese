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

// a guide point past the patch's four (MULTI: strand_eval reads its guides itself)
vec3 tese_guide_point(int k) {
#if MULTI
    return vec3(0.0);
#else
    return guide_point(p_guide, k);
#endif
}

void main() {
    float u = gl_TessCoord.x;
    int line = int(round(gl_TessCoord.y * gl_TessLevelOuter[0]));
    StrandVertex v = strand_eval(p_guide, p_seg, u, p_first_strand + line, p_lod_count, p_lod_t,
                                 c_pos[0], c_pos[1], c_pos[2], c_pos[3], c_normal[1], c_normal[2]);
    // the shading tangent: the direction between the drawn points on either side (strand_eval.glsl),
    // the strand evaluated a step before and after, on the neighbouring guide segment past this
    // one's ends (its own cubic carried past them would move the clump's frame off); at the root
    // and the tip the strand's own point
    float du = 1.0 / max(gl_TessLevelOuter[1], 1.0);
    int strand = p_first_strand + line;
    vec3 a = v.pos, b = v.pos;
    if (u - du >= -1e-6) {
        a = strand_eval(p_guide, p_seg, max(u - du, 0.0), strand, p_lod_count, p_lod_t,
                        c_pos[0], c_pos[1], c_pos[2], c_pos[3], c_normal[1], c_normal[2]).pos;
    } else if (p_seg > 0) {
        a = strand_eval(p_guide, p_seg - 1, 1.0 - du, strand, p_lod_count, p_lod_t,
                        tese_guide_point(p_seg - 2), c_pos[0], c_pos[1], c_pos[2], c_normal[0], c_normal[1]).pos;
    }
    if (u + du <= 1.0 + 1e-6) {
        b = strand_eval(p_guide, p_seg, min(u + du, 1.0), strand, p_lod_count, p_lod_t,
                        c_pos[0], c_pos[1], c_pos[2], c_pos[3], c_normal[1], c_normal[2]).pos;
    } else if (p_seg < u_n - 2) {
        b = strand_eval(p_guide, p_seg + 1, du, strand, p_lod_count, p_lod_t,
                        c_pos[1], c_pos[2], c_pos[3], tese_guide_point(p_seg + 3), c_normal[2], c_normal[3]).pos;
    }
    e_pos = v.pos;
    e_tangent = strand_tilted(strand_curve_tangent(a, b, v.tangent), v);
    e_s = v.s;
    e_rand = v.rand;
    e_width = v.width;
    e_id = v.id;
    e_lod_alpha = v.lod_alpha;
}
