#version 430 core
// Grid friction: per node, velocity = momentum / mass; writes grid[n] = (v, mass) and clears the
// atomic accumulator for the next step (METHOD_ATOMIC) or reads the blended 3D texture (METHOD_RASTER).
layout(local_size_x = 256) in;

layout(std430, binding = 3) writeonly buffer Grid { vec4 grid[]; };

#if METHOD_ATOMIC
layout(std430, binding = 2) buffer Accumulator { uint acc[]; };
#define FIXED_ACC acc
#include "fixed64.glsl"
#else
uniform sampler3D splat_texture;
#endif

uniform float min_mass;

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n >= uint(GRID_RES * GRID_RES * GRID_RES)) return;
#if METHOD_ATOMIC
    uint b = n * 8u;
    double m = fixed_load(b);
    dvec3 mv = dvec3(fixed_load(b + 2u), fixed_load(b + 4u), fixed_load(b + 6u));
    for (uint k = 0u; k < 8u; ++k) acc[b + k] = 0u;
    vec3 v = (m > double(min_mass)) ? vec3(mv / m) : vec3(0.0);
    grid[n] = vec4(v, float(m));
#else
    ivec3 c = ivec3(int(n) % GRID_RES, (int(n) / GRID_RES) % GRID_RES, int(n) / (GRID_RES * GRID_RES));
    vec4 t = texelFetch(splat_texture, c, 0);
    vec3 v = (t.w > min_mass) ? t.xyz / t.w : vec3(0.0);
    grid[n] = vec4(v, t.w);
#endif
}
