#version 430 core
// Grid friction, rasterised splat (Woodhouse's optimised_gpu): one point per particle.
layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) readonly buffer Velocities { vec4 velocities[]; };
#include "grid_nodes.glsl"

uniform float pinned_mass;
uniform float inv_mass_unit;

out VS_OUT {
    flat ivec3 base;
    vec3 frac;
    vec4 value;   // (m v, m)
} vs_out;

void main() {
    vec4 p = positions[gl_VertexID];
    float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
    NodeStencil s = node_stencil(p.xyz);
    vs_out.base = s.base;
    vs_out.frac = s.frac;
    vs_out.value = (m > 0.0) ? vec4(m * velocities[gl_VertexID].xyz, m) : vec4(0.0);
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
