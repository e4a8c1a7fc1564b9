#version 430 core
// PCG: q = A d on fluid cells (A: diag = non-solid neighbours, -1 per fluid neighbour, air p = 0).
// Partials: (d . q, 0).
layout(local_size_x = 256) in;

#include "flip_grid.glsl"
layout(std430, binding = B_CELLS) buffer Cells { Cell cells[]; };
#include "pcg_reduce.glsl"

void main() {
    uint n = gl_GlobalInvocationID.x;
    double dq = 0.0lf;
    if (n < NUM_CELLS && cells[n].marker == FLUID) {
        ivec3 cc = cell_coord(n);
        float d = cells[n].d;
        float q = cells[n].diag * d;
        for (int a = 0; a < 3; ++a) {
            ivec3 e = ivec3(0); e[a] = 1;
            ivec3 up = cc + e, dn = cc - e;
            if (in_domain(up) && cells[cell_index(up)].marker == FLUID) q -= cells[cell_index(up)].d;
            if (in_domain(dn) && cells[cell_index(dn)].marker == FLUID) q -= cells[cell_index(dn)].d;
        }
        cells[n].q = q;
        dq = double(d) * double(q);
    }
    workgroup_reduce(dq, 0.0lf);
}
