#version 430 core
// PCG: p += alpha d, r -= alpha q, z = r / diag. Partials: (r . z, max |r|).
layout(local_size_x = 256) in;

#include "flip_grid.glsl"
layout(std430, binding = B_CELLS) buffer Cells { Cell cells[]; };
#include "pcg_reduce.glsl"
#include "pcg_scalars.glsl"

void main() {
    uint n = gl_GlobalInvocationID.x;
    double rz = 0.0lf, rmax = 0.0lf;
    if (n < NUM_CELLS && cells[n].marker == FLUID) {
        Cell c = cells[n];
        float alpha = float(pcg_alpha);
        c.p += alpha * c.d;
        c.r -= alpha * c.q;
        c.z = c.diag > 0.0 ? c.r / c.diag : 0.0;
        cells[n] = c;
        rz = double(c.r) * double(c.z);
        rmax = abs(double(c.r));
    }
    workgroup_reduce(rz, rmax);
}
