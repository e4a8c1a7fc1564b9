#version 430 core
// NaN guard (one thread per strand): a strand with a non-finite position or velocity,
// a speed above max_speed_abs, or a particle farther from its root than
// max_stretch * rest arc + 1 cm goes back to its last valid positions (prev_positions
// when they pass the same tests, else its rest pose under the head) with zero velocity.
// guard[0] counts recoveries; guard[1] keeps the largest recovered strand + 1.
#include "sim_common.glsl"

layout(local_size_x = 64) in;

uniform mat4 head;
uniform float max_stretch;
uniform float max_speed_abs;

void main() {
    uint s = gl_GlobalInvocationID.x;
    if (s >= num_strands) return;
    uint base = s * uint(NV);
    vec3 root = positions[base].xyz;
    bool bad = false;
    for (uint k = 0u; k < uint(NV); ++k) {
        uint i = base + k;
        vec4 x = positions[i];
        vec3 v = velocities[i].xyz;
        if (!finite3(x.xyz) || !finite3(v) || !finite3(root)) { bad = true; break; }
        if (!(length(v) <= max_speed_abs)) { bad = true; break; }
        if (!(length(x.xyz - root) <= max_stretch * rest_info[i].y + 0.01)) { bad = true; break; }
    }
    if (!bad) return;
    // the previous positions are a valid state when finite and not stretched absurdly
    // (an absurd value written between steps is in them too)
    bool prev_ok = true;
    vec3 prev_root = prev_positions[base].xyz;
    for (uint k = 0u; k < uint(NV); ++k) {
        vec3 x = prev_positions[base + k].xyz;
        if (!finite3(x) || !(length(x - prev_root) <= max_stretch * rest_info[base + k].y + 0.01))
            prev_ok = false;
    }
    for (uint k = 0u; k < uint(NV); ++k) {
        uint i = base + k;
        vec4 rest = rest_positions[i];
        vec3 x = (prev_ok && rest.w > 0.0) ? prev_positions[i].xyz : transform_point(head, rest.xyz);
        positions[i] = vec4(x, rest.w);
        prev_positions[i] = vec4(x, rest.w);
        velocities[i] = vec4(0.0);
        corrections[i] = vec4(0.0);
    }
    atomicAdd(guard[0], 1u);
    atomicMax(guard[1], s + 1u);
}
