#version 430 core
// Dynamic Follow-The-Leader (Müller, Kim, Chentanez 2012), one thread per strand:
//   p_k = p_{k-1} + l_k * normalize(p_k - p_{k-1}),   d_k = p_k(new) - p_k(predicted)
// for k = 1 .. N-1 root to tip; pinned particles stay and lead. d_k is stored for the
// velocity correction v_k += s_damping * (-d_{k+1}) / dt (velocity.comp).
// A segment of zero length takes the direction of its rest segment under the head.
#include "sim_common.glsl"

layout(local_size_x = 64) in;

uniform mat4 head;

void main() {
    uint s = gl_GlobalInvocationID.x;
    if (s >= num_strands) return;
    uint base = s * uint(NV);
    mat3 H = mat3(head);
    vec3 prev = positions[base].xyz;
    corrections[base] = vec4(0.0);
    for (uint k = 1u; k < uint(NV); ++k) {
        uint i = base + k;
        vec4 x = positions[i];
        if (rest_positions[i].w == 0.0) {
            corrections[i] = vec4(0.0);
            prev = x.xyz;
            continue;
        }
        vec3 d = x.xyz - prev;
        float len = length(d);
        vec3 dir;
        if (!finite3(d)) {
            dir = d;  // let NaN through: the guard resets the strand
        } else if (len > 1e-12) {
            dir = d / len;
        } else {
            vec3 r = H * (rest_positions[i].xyz - rest_positions[i - 1u].xyz);
            dir = length(r) > 1e-12 ? normalize(r) : vec3(0.0, -1.0, 0.0);
        }
        vec3 p = prev + rest_info[i].x * dir;
        corrections[i] = vec4(p - x.xyz, 0.0);
        positions[i] = vec4(p, x.w);
        prev = p;
    }
}
