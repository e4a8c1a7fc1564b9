#version 430 core
// FLIP particle -> grid: each velocity component goes to the 8 faces of its staggered stencil
// with trilinear weights (mass * w and mass * w * v, 64-bit fixed point); cells count their
// particles (fluid marker) and collect trilinear mass at their centres (density).
layout(local_size_x = 128) in;

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) readonly buffer Velocities { vec4 velocities[]; };
layout(std430, binding = B_ACCUMULATOR) coherent buffer Accumulator { uint acc[]; };
#define FIXED_ACC acc
#include "fixed64.glsl"
#include "flip_grid.glsl"
// acc: 4 words per face (mass lo/hi, momentum lo/hi) for 3 * FACES_PER_AXIS faces, then
// 4 words per cell (density lo/hi, particle count, unused).
#define CELL_ACC(n) (3u * FACES_PER_AXIS * 4u + (n) * 4u)

uniform uint num_particles;
uniform float pinned_mass;
uniform float inv_mass_unit;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_particles) return;
    vec4 p = positions[i];
    if (any(isnan(p.xyz)) || any(isinf(p.xyz))) return;
    float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
    if (!(m > 0.0)) return;
    vec3 v = velocities[i].xyz;
    float h = grid_h();
    vec3 g = (p.xyz - grid_origin(h)) / h;
    for (int a = 0; a < 3; ++a) {
        FaceStencil s = face_stencil(a, g);
        for (int c = 0; c < 8; ++c) {
            ivec3 o = corner_offset(c);
            float mw = m * corner_weight(s.frac, o);
            if (mw == 0.0) continue;
            uint f = face_index(a, s.base + o) * 4u;
            fixed_add(f, mw);
            fixed_add(f + 2u, mw * v[a]);
        }
    }
    ivec3 cell = clamp(ivec3(floor(g)), ivec3(0), ivec3(R - 1));
    atomicAdd(acc[CELL_ACC(cell_index(cell)) + 2u], 1u);
    vec3 gc = clamp(g - vec3(0.5), vec3(0.0), vec3(float(R - 1)));
    ivec3 base = min(ivec3(floor(gc)), ivec3(R - 2));
    vec3 f = gc - vec3(base);
    for (int c = 0; c < 8; ++c) {
        ivec3 o = corner_offset(c);
        float mw = m * corner_weight(f, o);
        if (mw != 0.0) fixed_add(CELL_ACC(cell_index(base + o)), mw);
    }
}
