#version 430
// Test and debugging harness: light 0's visibility (the SHADOWS method's look-up in
// lighting.glsl, the head's shadow map included) at given world points, into a buffer.
layout(local_size_x = 64) in;
#include "lighting.glsl"
layout(std430, binding = B_PROBE_POINTS) readonly buffer ProbePoints { vec4 probe_points[]; };
layout(std430, binding = B_PROBE_OUT) writeonly buffer ProbeOut { float probe_out[]; };
uniform int u_probe_count;

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= u_probe_count) return;
    probe_out[i] = light0_visibility(probe_points[i].xyz);
}
