#version 430
// Isolines: outer[0] = strands drawn from this guide segment (<= 64 per instance),
// outer[1] = tessellated segments per guide segment.
#include "strand_common.glsl"
layout(vertices = 4) out;

in vec3 v_pos[];
in vec3 v_normal[];
flat in int v_patch[];
flat in int v_instance[];
out vec3 c_pos[];
out vec3 c_normal[];
patch out int p_guide;
patch out int p_seg;
patch out int p_first_strand;

void main() {
    c_pos[gl_InvocationID] = v_pos[gl_InvocationID];
    c_normal[gl_InvocationID] = v_normal[gl_InvocationID];
    if (gl_InvocationID == 0) {
        int segs = u_n - 1;
        p_guide = v_patch[0] / segs;
        p_seg = v_patch[0] - p_guide * segs;
        p_first_strand = v_instance[0] * 64;
        int lines = clamp(u_strands_per_guide - p_first_strand, 0, 64);
        gl_TessLevelOuter[0] = float(lines);
        gl_TessLevelOuter[1] = float(u_subdivisions);
    }
}
