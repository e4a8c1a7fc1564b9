#version 430
// Fill an r32ui image with u_value (a buffer's words: mane/gpu/fill_words.comp).
layout(local_size_x = 256) in;
layout(binding = IMG_CLEAR, r32ui) uniform writeonly uimage2D u_image;
uniform ivec2 u_size;
uniform uint u_value;
void main() {
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256u;
    if (i >= uint(u_size.x * u_size.y)) return;
    imageStore(u_image, ivec2(int(i) % u_size.x, int(i) / u_size.x), uvec4(u_value));
}
