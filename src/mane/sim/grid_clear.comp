#version 430 core
// Zeroes the first num_words words of the buffer at binding 2 (GridFriction.clear_accumulator):
// a GPU-side clear, unlike moderngl's Buffer.clear(), which maps the buffer for the CPU.
layout(local_size_x = 256) in;
layout(std430, binding = B_ACCUMULATOR) writeonly buffer Words { uint words[]; };
uniform uint num_words;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < num_words) words[i] = 0u;
}
