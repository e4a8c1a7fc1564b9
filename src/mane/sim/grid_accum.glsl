// The grid friction accumulator at binding 2: per node the sums of m w and m w v.
//   ACC_FLOAT = 1: 4 floats per node (mass, momentum xyz), float atomicAdd
//                  (GL_NV_shader_atomic_float; the including .comp enables it first thing).
//   ACC_FLOAT = 0: 8 uints per node, each sum a (low, high) 64-bit fixed-point pair
//                  (fixed64.glsl): exact and order-independent, any GL 4.3 with fp64.
// Both store the same quantities in the same node order; only the number format differs.
#ifndef ACC_FLOAT
#define ACC_FLOAT 0
#endif

#if ACC_FLOAT
#define ACC_WORDS 4u
layout(std430, binding = B_ACCUMULATOR) buffer Accumulator { float acc[]; };
#else
#define ACC_WORDS 8u
layout(std430, binding = B_ACCUMULATOR) buffer Accumulator { uint acc[]; };
#define FIXED_ACC acc
#endif
#include "fixed64.glsl"

// acc[node] += (m, mv): four atomics (float) or four 64-bit fixed-point additions.
void acc_add(uint node, float m, vec3 mv) {
    uint b = node * ACC_WORDS;
#if ACC_FLOAT
    atomicAdd(acc[b], m);
    atomicAdd(acc[b + 1u], mv.x);
    atomicAdd(acc[b + 2u], mv.y);
    atomicAdd(acc[b + 3u], mv.z);
#else
    fixed_add(b, m);
    fixed_add(b + 2u, mv.x);
    fixed_add(b + 4u, mv.y);
    fixed_add(b + 6u, mv.z);
#endif
}

// (V, mass) of a node, V = momentum / mass (0 where mass <= min_mass); clears the node.
vec4 acc_take_velocity(uint node, float min_mass) {
    uint b = node * ACC_WORDS;
#if ACC_FLOAT
    float m = acc[b];
    vec3 mv = vec3(acc[b + 1u], acc[b + 2u], acc[b + 3u]);
    vec3 v = (m > min_mass) ? mv / m : vec3(0.0);
    float mass = m;
#else
    double m = fixed_load(b);
    dvec3 mv = dvec3(fixed_load(b + 2u), fixed_load(b + 4u), fixed_load(b + 6u));
    vec3 v = (m > double(min_mass)) ? vec3(mv / m) : vec3(0.0);
    float mass = float(m);
#endif
#if ACC_FLOAT
    for (uint k = 0u; k < ACC_WORDS; ++k) acc[b + k] = 0.0;
#else
    for (uint k = 0u; k < ACC_WORDS; ++k) acc[b + k] = 0u;
#endif
    return vec4(v, mass);
}
