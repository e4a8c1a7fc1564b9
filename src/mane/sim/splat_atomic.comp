#version 430 core
// Grid friction, atomic splat: each particle adds m*w and m*w*v to its 8 nodes in 64-bit fixed point.
layout(local_size_x = 128) in;

layout(std430, binding = 0) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 1) readonly buffer Velocities { vec4 velocities[]; };
// per node 8 words: mass, momentum x, y, z; each a (low, high) pair
layout(std430, binding = 2) coherent buffer Accumulator { uint acc[]; };
#define FIXED_ACC acc
#include "fixed64.glsl"
#include "grid_nodes.glsl"

uniform uint num_particles;
uniform float pinned_mass;
uniform float inv_mass_unit;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_particles) return;
    vec4 p = positions[i];
    float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
    if (!(m > 0.0)) return;
    vec3 v = velocities[i].xyz;
    NodeStencil s = node_stencil(p.xyz);
    for (int c = 0; c < 8; ++c) {
        ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        float mw = m * corner_weight(s.frac, corner);
        if (mw == 0.0) continue;
        uint base = node_index(s.base + corner) * 8u;
        fixed_add(base + 0u, mw);
        fixed_add(base + 2u, mw * v.x);
        fixed_add(base + 4u, mw * v.y);
        fixed_add(base + 6u, mw * v.z);
    }
}
