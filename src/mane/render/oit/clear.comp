#version 430
// Fill an r32ui image (CLEAR_IMAGE 1) or a uint buffer (CLEAR_IMAGE 0) with u_value.
layout(local_size_x = 256) in;
#if CLEAR_IMAGE
layout(binding = IMG_CLEAR, r32ui) uniform writeonly uimage2D u_image;
uniform ivec2 u_size;
#else
layout(std430, binding = B_CLEAR) writeonly buffer Data { uint data[]; };
uniform uint u_count;
#endif
uniform uint u_value;
void main() {
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256u;
#if CLEAR_IMAGE
    if (i >= uint(u_size.x * u_size.y)) return;
    imageStore(u_image, ivec2(int(i) % u_size.x, int(i) / u_size.x), uvec4(u_value));
#else
    if (i >= u_count) return;
    data[i] = u_value;
#endif
}
