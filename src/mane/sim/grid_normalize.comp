#version 430 core
#if METHOD_ATOMIC && ACC_FLOAT
#extension GL_NV_shader_atomic_float : require
#endif
// Grid friction: per node, velocity = momentum / mass; writes grid[n] = (v, mass) and clears the
// atomic accumulator for the next step (METHOD_ATOMIC, grid_accum.glsl) or reads the blended
// 3D texture (METHOD_RASTER).
layout(local_size_x = 256) in;

layout(std430, binding = B_GRID) writeonly buffer Grid { vec4 grid[]; };

#if METHOD_ATOMIC
#include "grid_accum.glsl"
#else
uniform sampler3D splat_texture;
#endif

uniform float min_mass;

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n >= uint(GRID_RES * GRID_RES * GRID_RES)) return;
#if METHOD_ATOMIC
    grid[n] = acc_take_velocity(n, min_mass);
#else
    ivec3 c = ivec3(int(n) % GRID_RES, (int(n) / GRID_RES) % GRID_RES, int(n) / (GRID_RES * GRID_RES));
    vec4 t = texelFetch(splat_texture, c, 0);
    vec3 v = (t.w > min_mass) ? t.xyz / t.w : vec3(0.0);
    grid[n] = vec4(v, t.w);
#endif
}
