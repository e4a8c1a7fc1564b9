#version 430 core
// PCG: d = z + beta d.
layout(local_size_x = 256) in;

#include "flip_grid.glsl"
layout(std430, binding = B_CELLS) buffer Cells { Cell cells[]; };
#include "pcg_scalars.glsl"

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n < NUM_CELLS && cells[n].marker == FLUID)
        cells[n].d = cells[n].z + float(pcg_beta) * cells[n].d;
}
