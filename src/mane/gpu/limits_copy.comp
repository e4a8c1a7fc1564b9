#version 430
// mane bench limits: a streaming copy, one uvec4 (16 bytes) a thread, over buffers much larger
// than the L2: the DRAM bandwidth the kernels can reach (bytes read + bytes written per second).
layout(local_size_x = 256) in;
layout(std430, binding = B_SRC) readonly buffer Src { uvec4 src[]; };
layout(std430, binding = B_DST) writeonly buffer Dst { uvec4 dst[]; };
uniform uint u_count;   // uvec4s to copy

void main() {
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
             + gl_LocalInvocationID.x;
    if (i < u_count) dst[i] = src[i];
}
