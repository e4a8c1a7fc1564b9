#version 430
// Test and debugging harness: light 0's visibility (the SHADOWS method's look-up in
// lighting.glsl, the head's shadow map included) at given world points, into a buffer;
// u_probe_term 1..3: light0_visibility_ms's (direct, multiple scattering, behind) instead.
layout(local_size_x = 64) in;
#include "lighting.glsl"
layout(std430, binding = B_PROBE_POINTS) readonly buffer ProbePoints { vec4 probe_points[]; };
layout(std430, binding = B_PROBE_OUT) writeonly buffer ProbeOut { float probe_out[]; };
uniform int u_probe_count;
uniform int u_probe_term;

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= u_probe_count) return;
    vec3 P = probe_points[i].xyz;
    probe_out[i] = u_probe_term == 0 ? light0_visibility(P) : light0_visibility_ms(P)[u_probe_term - 1];
}
