#version 430
// Isolines: outer[0] = strands drawn from this guide segment (<= 64 per instance),
// outer[1] = tessellated segments per guide segment. LOD: both fall with the distance from
// the camera to the guide's root (outer[1] fractional; outer[0] drops the last strands, the
// evaluation stage fades the one going).
#include "strand_common.glsl"
layout(vertices = 4) out;

in vec3 v_pos[];
in vec3 v_normal[];
flat in int v_patch[];
flat in int v_instance[];
out vec3 c_pos[];
out vec3 c_normal[];
patch out int p_guide;          // MULTI: the group of 64 rendered strands
patch out int p_seg;
patch out int p_first_strand;   // MULTI: the rendered strand (record) of line 0
patch out float p_lod_count;    // strands kept of this guide (fractional), LOD single mode
patch out float p_lod_t;

void main() {
    c_pos[gl_InvocationID] = v_pos[gl_InvocationID];
    c_normal[gl_InvocationID] = v_normal[gl_InvocationID];
    if (gl_InvocationID == 0) {
        int segs = u_n - 1;
        p_guide = v_patch[0] / segs;
        p_seg = v_patch[0] - p_guide * segs;
#if MULTI
        p_first_strand = p_guide * 64;
        int lines = clamp(u_num_render - p_first_strand, 0, 64);
        vec3 root = guide_point(strand_table[min(p_first_strand, u_num_render - 1)].guides.x, 0);
#else
        p_first_strand = v_instance[0] * 64;
        int lines = clamp(u_strands_per_guide - p_first_strand, 0, 64);
        vec3 root = guide_point(p_guide, 0);
#endif
        float level = float(u_subdivisions);
        p_lod_count = float(u_strands_per_guide);
        p_lod_t = 0.0;
#if LOD
        float t = lod_t(root);
        p_lod_t = t;
        float wanted = max(u_lod_segments.y, float(u_segments) * mix(1.0, u_lod_segments.x, t));
        level = clamp(wanted / float(segs), 1.0, 63.0);
#if !MULTI
        p_lod_count = mix(1.0, u_lod_range.z, t) * float(u_strands_per_guide);
        int keep = clamp(int(ceil(p_lod_count - 1e-6)), 1, u_strands_per_guide);
        lines = clamp(keep - p_first_strand, 0, 64);
#endif
#endif
        gl_TessLevelOuter[0] = float(lines);
        gl_TessLevelOuter[1] = level;
    }
}
