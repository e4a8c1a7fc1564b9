#version 430 core
// Grid friction (Petrovic et al. 2005): v <- (1 - f) v + f * v_grid, v_grid the trilinear
// interpolation of the node velocities. Pinned particles (w = 0) are left alone.
layout(local_size_x = 128) in;

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) buffer Velocities { vec4 velocities[]; };
layout(std430, binding = B_GRID) readonly buffer Grid { vec4 grid[]; };
#include "grid_nodes.glsl"
#include "grid_velocity.glsl"

uniform uint num_particles;
uniform float friction;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_particles) return;
    vec4 p = positions[i];
    if (p.w == 0.0) return;
    vec4 v = velocities[i];
    velocities[i] = vec4(mix(v.xyz, grid_velocity(p.xyz), friction), v.w);
}
