#version 430 core
// FLIP face velocities: u* = sum(m w v) / sum(m w); faces touching a solid cell take the solid's
// velocity (0, static colliders). Writes faces[f] = (u, u*) and clears the face accumulators.
layout(local_size_x = 256) in;

layout(std430, binding = B_ACCUMULATOR) buffer Accumulator { uint acc[]; };
#define FIXED_ACC acc
#include "fixed64.glsl"
#include "flip_grid.glsl"
layout(std430, binding = B_FACES) writeonly buffer Faces { vec2 faces[]; };
layout(std430, binding = B_CELLS) readonly buffer Cells { Cell cells[]; };

uint marker_at(ivec3 c) { return in_domain(c) ? cells[cell_index(c)].marker : AIR; }

void main() {
    uint f = gl_GlobalInvocationID.x;
    if (f >= 3u * FACES_PER_AXIS) return;
    int a = int(f / FACES_PER_AXIS);
    ivec3 fc = face_coord(a, f - uint(a) * FACES_PER_AXIS);
    uint b = f * 4u;
    double m = fixed_load(b);
    double mv = fixed_load(b + 2u);
    acc[b] = 0u; acc[b + 1u] = 0u; acc[b + 2u] = 0u; acc[b + 3u] = 0u;
    float ustar = m > 0.0lf ? float(mv / m) : 0.0;
    ivec3 e = ivec3(0); e[a] = 1;
    bool solid = marker_at(fc - e) == SOLID || marker_at(fc) == SOLID;
    faces[f] = vec2(solid ? 0.0 : ustar, ustar);
}
