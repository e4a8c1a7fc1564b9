#version 430 core
// Set the first u_count 32-bit words of a buffer to u_value on the GPU (mane/gpu/clear.py): a
// large buffer's initial contents without building them in host memory and uploading them.
// Grid-stride: any count with a bounded number of work groups.
layout(local_size_x = 256) in;
layout(std430, binding = B_FILL) writeonly buffer Words { uint words[]; };
uniform uint u_count;
uniform uint u_value;

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint i = gl_GlobalInvocationID.x; i < u_count; i += stride)
        words[i] = u_value;
}
