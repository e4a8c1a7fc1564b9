#version 430 core
// NaN guard: a strand with a non-finite position or velocity, a speed above max_speed_abs,
// or a particle farther from its root than max_stretch * rest arc + 1 cm goes back to its
// last valid positions (prev_positions when they pass the same tests, else its rest pose
// under the head) with zero velocity. guard[0] counts recoveries; guard[1] keeps the
// largest recovered strand + 1.
// One thread per particle, SPG whole strands per work group (GROUP_SIZE = SPG * NV, both
// injected by the simulator): the particles' verdicts meet in shared memory, so the reads
// are coalesced and a strand's particles are tested side by side.
#include "sim_common.glsl"

layout(local_size_x = GROUP_SIZE) in;

uniform mat4 head;
uniform float max_stretch;
uniform float max_speed_abs;

shared uint bad[SPG];
shared uint prev_bad[SPG];

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint ls = lid / uint(NV);
    uint s = gl_WorkGroupID.x * uint(SPG) + ls;
    bool live = s < num_strands;
    uint base = s * uint(NV);
    uint i = base + (lid - ls * uint(NV));
    if (lid < uint(SPG)) {
        bad[lid] = 0u;
        prev_bad[lid] = 0u;
    }
    barrier();
    float reach = 0.0;
    if (live) {
        reach = max_stretch * rest_info[i].y + 0.01;
        vec3 root = positions[base].xyz;
        vec3 x = positions[i].xyz;
        vec3 v = velocities[i].xyz;
        bool ok = finite3(x) && finite3(v) && finite3(root) && length(v) <= max_speed_abs
                  && length(x - root) <= reach;
        if (!ok) atomicOr(bad[ls], 1u);
    }
    barrier();
    bool reset = live && bad[ls] != 0u;  // barriers below stay in uniform control flow
    // the previous positions are a valid state when finite and not stretched absurdly
    // (an absurd value written between steps is in them too)
    vec3 xp = vec3(0.0);
    if (reset) {
        xp = prev_positions[i].xyz;
        if (!finite3(xp) || !(length(xp - prev_positions[base].xyz) <= reach)) atomicOr(prev_bad[ls], 1u);
    }
    barrier();
    if (!reset) return;
    vec4 rest = rest_positions[i];
    vec3 x = (prev_bad[ls] == 0u && rest.w > 0.0) ? xp : transform_point(head, rest.xyz);
    positions[i] = vec4(x, rest.w);
    prev_positions[i] = vec4(x, rest.w);
    velocities[i] = vec4(0.0);
    corrections[i] = vec4(0.0);
    if (i == base) {
        atomicAdd(guard[0], 1u);
        atomicMax(guard[1], s + 1u);
    }
}
