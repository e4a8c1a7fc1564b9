#version 430 core
#if ACC_FLOAT
#extension GL_NV_shader_atomic_float : require
#endif
// Grid friction, direct atomic splat: each particle adds m*w and m*w*v to its 8 nodes' global
// accumulator (grid_accum.glsl: float atomics or 64-bit fixed point). Every particle does 32
// global atomics (64 with fixed point); splat_binned.comp sums in shared memory first.
layout(local_size_x = 128) in;

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) readonly buffer Velocities { vec4 velocities[]; };
#include "grid_accum.glsl"
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
        acc_add(node_index(s.base + corner), mw, mw * v);
    }
}
