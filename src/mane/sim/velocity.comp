#version 430 core
// Velocity update (one thread per particle): v = (x - x_prev) / dt, plus DFTL's
// correction v_k += s_damping * (-d_{k+1}) / dt for free particles below the tip;
// |v| <= max_speed.
#include "sim_common.glsl"

layout(local_size_x = 64) in;

uniform float dt;
uniform float dftl_damping;  // 0 when the length method is PBD
uniform float max_speed;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_strands * uint(NV)) return;
    uint k = i % uint(NV);
    vec3 v = (positions[i].xyz - prev_positions[i].xyz) / dt;
    if (dftl_damping > 0.0 && k + 1u < uint(NV) && rest_positions[i].w > 0.0)
        v -= dftl_damping * corrections[i + 1u].xyz / dt;
    float speed = length(v);
    if (speed > max_speed) v *= max_speed / speed;
    velocities[i] = vec4(v, 0.0);
}
