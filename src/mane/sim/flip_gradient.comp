#version 430 core
// FLIP pressure gradient: u -= p(upper) - p(lower) on faces next to a fluid cell and no solid
// (the rho/dt factor was dropped from the solve, so it is dropped here too).
layout(local_size_x = 256) in;

#include "flip_grid.glsl"
layout(std430, binding = B_FACES) buffer Faces { vec2 faces[]; };
layout(std430, binding = B_CELLS) readonly buffer Cells { Cell cells[]; };

void main() {
    uint f = gl_GlobalInvocationID.x;
    if (f >= 3u * FACES_PER_AXIS) return;
    int a = int(f / FACES_PER_AXIS);
    ivec3 upper = face_coord(a, f - uint(a) * FACES_PER_AXIS);
    ivec3 e = ivec3(0); e[a] = 1;
    ivec3 lower = upper - e;
    uint ml = AIR, mu = AIR;
    float pl = 0.0, pu = 0.0;
    if (in_domain(lower)) { ml = cells[cell_index(lower)].marker; pl = cells[cell_index(lower)].p; }
    if (in_domain(upper)) { mu = cells[cell_index(upper)].marker; pu = cells[cell_index(upper)].p; }
    if (ml == SOLID || mu == SOLID) return;
    if (ml != FLUID && mu != FLUID) return;
    if (ml != FLUID) pl = 0.0;
    if (mu != FLUID) pu = 0.0;
    faces[f].x -= pu - pl;
}
