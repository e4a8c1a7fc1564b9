#version 430
// Sorted blending, last step: the index buffer of the sorted patches (4 control points each).
layout(local_size_x = 256) in;
layout(std430, binding = B_SORT_KEYS) readonly buffer SortKeys { uvec2 keys[]; };
layout(std430, binding = B_SORT_INDICES) writeonly buffer Indices { uint indices[]; };
uniform int u_patches;
void main() {
    int i = int(gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256u);
    if (i >= u_patches) return;
    uint p = keys[i].y;
    for (int j = 0; j < 4; ++j) indices[4 * i + j] = 4u * p + uint(j);
}
