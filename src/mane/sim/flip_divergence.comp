#version 430 core
// FLIP divergence and PCG start: on fluid cells b = S - D, D = sum of face differences (m/s),
// S = h * k * max(rho - rho0, 0) / (rho0 dt) the volume-preservation source (rho0 per cell, or
// a rest density per m^3 times h^3: the box, hence h, changes from step to step); r = b, p = 0,
// z = b / diag (Jacobi), d = z. Partials: (r . z, max |r|).
layout(local_size_x = 256) in;

#include "flip_grid.glsl"
layout(std430, binding = B_FACES) readonly buffer Faces { vec2 faces[]; };
layout(std430, binding = B_CELLS) buffer Cells { Cell cells[]; };
#include "pcg_reduce.glsl"

uniform float density_target;    // mass units per cell; <= 0: off
uniform float rest_density;      // mass units per m^3 (> 0: the target is rest_density h^3)
uniform float density_gain;      // k / dt (1/s)

uint marker_at(ivec3 c) { return in_domain(c) ? cells[cell_index(c)].marker : AIR; }

void main() {
    uint n = gl_GlobalInvocationID.x;
    double rz = 0.0lf, rmax = 0.0lf;
    if (n < NUM_CELLS) {
        Cell c = cells[n];
        if (c.marker == FLUID) {
            ivec3 cc = cell_coord(n);
            float D = 0.0;
            float diag = 0.0;
            for (int a = 0; a < 3; ++a) {
                ivec3 e = ivec3(0); e[a] = 1;
                D += faces[face_index(a, cc + e)].x - faces[face_index(a, cc)].x;
                diag += (marker_at(cc + e) != SOLID ? 1.0 : 0.0) + (marker_at(cc - e) != SOLID ? 1.0 : 0.0);
            }
            float S = 0.0;
            float h = grid_h();
            float target = rest_density > 0.0 ? rest_density * h * h * h : density_target;
            if (target > 0.0)
                S = h * density_gain * max(c.density - target, 0.0) / target;
            float b = diag > 0.0 ? S - D : 0.0;
            c.diag = diag;
            c.p = 0.0;
            c.r = b;
            c.z = diag > 0.0 ? b / diag : 0.0;
            c.d = c.z;
            c.q = 0.0;
            cells[n] = c;
            rz = double(c.r) * double(c.z);
            rmax = abs(double(c.r));
        }
    }
    workgroup_reduce(rz, rmax);
}
