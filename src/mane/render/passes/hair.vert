#version 430
// One patch per guide segment: 4 control points, the segment's ends and their neighbours.
// No vertex buffer: gl_VertexID = patch * 4 + j. MULTI: a patch is a segment of a group of
// up to 64 rendered strands; the evaluation stage reads the 3 guides itself.
#include "strand_common.glsl"

out vec3 v_pos;
out vec3 v_normal;
flat out int v_patch;
flat out int v_instance;

void main() {
    int patch_id = gl_VertexID / 4;
    int j = gl_VertexID - patch_id * 4;
    int segs = u_n - 1;
    int guide = patch_id / segs;
    int seg = patch_id - guide * segs;
    int k = seg - 1 + j;
#if MULTI
    v_pos = vec3(0.0);
    v_normal = vec3(0.0);
#else
    v_pos = guide_point(guide, k);
    v_normal = guide_normal(guide, k);
#endif
    v_patch = patch_id;
    v_instance = gl_InstanceID;
}
