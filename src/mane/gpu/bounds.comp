#version 430 core
// GridBounds: min/max of particle positions by atomicMin/atomicMax on order-preserving int keys
// (stage REDUCE), then padding and the cubic box (stage FINALIZE), all without a CPU readback.
#include "grid_bounds.glsl"

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };

uniform uint num_particles;
uniform float margin;            // metres added on every side
uniform float relative_margin;   // fraction of the largest extent added on every side
uniform float min_extent;        // metres; a box never gets thinner than this
uniform int cubic;               // 1: the box is a cube around the centre

const int KEY_POS_INF = 0x7f800000;   // float_key(+inf)
const int KEY_NEG_INF = int(0x807fffff); // float_key(-inf)

int float_key(float f) {
    int b = floatBitsToInt(f);
    return b >= 0 ? b : b ^ 0x7fffffff;
}
float key_float(int k) {
    return intBitsToFloat(k >= 0 ? k : k ^ 0x7fffffff);
}

#if STAGE_REDUCE
layout(local_size_x = 256) in;
shared ivec3 s_min[256];
shared ivec3 s_max[256];
void main() {
    uint t = gl_LocalInvocationID.x;
    ivec3 kmin = ivec3(KEY_POS_INF);
    ivec3 kmax = ivec3(KEY_NEG_INF);
    // PER_INVOCATION particles per invocation (coalesced: stride 256), fewer groups to reduce
    uint first = gl_WorkGroupID.x * 256u * uint(PER_INVOCATION) + t;
    for (uint r = 0u; r < uint(PER_INVOCATION); ++r) {
        uint i = first + r * 256u;
        if (i >= num_particles) break;
        vec3 p = positions[i].xyz;
        if (!any(isnan(p)) && !any(isinf(p))) {
            ivec3 k = ivec3(float_key(p.x), float_key(p.y), float_key(p.z));
            kmin = min(kmin, k);
            kmax = max(kmax, k);
        }
    }
    s_min[t] = kmin;
    s_max[t] = kmax;
    barrier();
    for (uint s = 128u; s > 0u; s >>= 1) {
        if (t < s) {
            s_min[t] = min(s_min[t], s_min[t + s]);
            s_max[t] = max(s_max[t], s_max[t + s]);
        }
        barrier();
    }
    if (t == 0u) {
        ivec3 a = s_min[0], b = s_max[0];
        if (a.x != KEY_POS_INF) {
            atomicMin(bounds_keys[0], a.x); atomicMin(bounds_keys[1], a.y); atomicMin(bounds_keys[2], a.z);
            atomicMax(bounds_keys[4], b.x); atomicMax(bounds_keys[5], b.y); atomicMax(bounds_keys[6], b.z);
        }
    }
}
#endif

#if STAGE_FINALIZE
layout(local_size_x = 1) in;
void main() {
    vec3 lo, hi;
    if (bounds_keys[0] == KEY_POS_INF) {   // no finite particle
        lo = vec3(0.0);
        hi = vec3(0.0);
    } else {
        lo = vec3(key_float(bounds_keys[0]), key_float(bounds_keys[1]), key_float(bounds_keys[2]));
        hi = vec3(key_float(bounds_keys[4]), key_float(bounds_keys[5]), key_float(bounds_keys[6]));
    }
    vec3 extent = hi - lo;
    float pad = margin + relative_margin * max(extent.x, max(extent.y, extent.z));
    lo -= vec3(pad);
    hi += vec3(pad);
    vec3 centre = 0.5 * (lo + hi);
    vec3 half_size = max(0.5 * (hi - lo), vec3(0.5 * min_extent));
    if (cubic != 0) half_size = vec3(max(half_size.x, max(half_size.y, half_size.z)));
    // axes that were not widened keep their exact padded min/max
    bvec3 widened = greaterThan(half_size, 0.5 * (hi - lo));
    bounds_lo = vec4(mix(lo, centre - half_size, widened), 0.0);
    bounds_hi = vec4(mix(hi, centre + half_size, widened), 0.0);
    // reset the keys for the next reduction
    for (int k = 0; k < 4; ++k) {
        bounds_keys[k] = KEY_POS_INF;
        bounds_keys[k + 4] = KEY_NEG_INF;
    }
}
#endif
