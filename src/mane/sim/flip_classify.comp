#version 430 core
// FLIP cell classification: SOLID where the optional SDF is below SOLID_LEVEL at the centre,
// FLUID where a particle lies, AIR elsewhere. Reads and clears the cell accumulators.
layout(local_size_x = 256) in;

layout(std430, binding = B_ACCUMULATOR) buffer Accumulator { uint acc[]; };
#define FIXED_ACC acc
#include "fixed64.glsl"
#include "flip_grid.glsl"
layout(std430, binding = B_CELLS) buffer Cells { Cell cells[]; };
#define CELL_ACC(n) (3u * FACES_PER_AXIS * 4u + (n) * 4u)

#if HAS_SDF
#include "sdf_sample.glsl"
uniform mat4 world_to_sdf;
uniform float solid_level;
#endif

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n >= NUM_CELLS) return;
    uint b = CELL_ACC(n);
    float density = float(fixed_load(b));
    uint count = acc[b + 2u];
    acc[b] = 0u; acc[b + 1u] = 0u; acc[b + 2u] = 0u;
    uint marker = count > 0u ? FLUID : AIR;
#if HAS_SDF
    float h = grid_h();
    vec3 centre = grid_origin(h) + (vec3(cell_coord(n)) + 0.5) * h;
    vec3 local = (world_to_sdf * vec4(centre, 1.0)).xyz;
    if (sdf_value(local) < solid_level) marker = SOLID;
#endif
    Cell c;
    c.p = 0.0; c.r = 0.0; c.z = 0.0; c.d = 0.0; c.q = 0.0;
    c.density = density;
    c.marker = marker;
    c.diag = 0.0;
    cells[n] = c;
}
