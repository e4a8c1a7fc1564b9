// mane/gpu/shaders/common.glsl: constants, hashing, random numbers and small maths
// shared by the simulation and render shaders.
//
//     #include "common.glsl"      (resolved by mane.gpu.glsl, beside the file or here)
//
// Included once per program (the loader skips repeats). Everything here is pure
// (no buffers, no uniforms), so it is legal in every stage.
// NumPy twins of pcg_hash and rand01 (checked against these) are in tests/test_gpu_common.py.

#ifndef MANE_COMMON_GLSL
#define MANE_COMMON_GLSL

const float PI = 3.14159265358979323846;
const float TWO_PI = 6.28318530717958647692;
const float HALF_PI = 1.57079632679489661923;
const float INV_PI = 0.31830988618379067154;
const float EPSILON = 1e-6;

// ---------------------------------------------------------------- hashing and random numbers

// PCG hash (Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020).
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint hash2(uint a, uint b) { return pcg_hash(a ^ pcg_hash(b)); }
uint hash3(uint a, uint b, uint c) { return pcg_hash(a ^ pcg_hash(b ^ pcg_hash(c))); }

// A uint to a float in [0, 1): the top 24 bits, exactly representable.
float uint_to_unit_float(uint h) { return float(h >> 8u) * (1.0 / 16777216.0); }

// A stateless random float in [0, 1) for (index, seed).
float rand01(uint index, uint seed) { return uint_to_unit_float(hash2(index, seed)); }

// A random stream: seed it once, draw as many as needed.
//     uint rng = rng_seed(strand_id, frame);  float u = rng_next(rng);
uint rng_seed(uint a, uint b) { return hash2(a, b); }
float rng_next(inout uint state) {
    state = state * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return uint_to_unit_float((word >> 22u) ^ word);
}
vec2 rng_next2(inout uint state) { float a = rng_next(state); return vec2(a, rng_next(state)); }
vec3 rng_next3(inout uint state) { vec2 a = rng_next2(state); return vec3(a, rng_next(state)); }

// A random unit vector, uniform on the sphere, from two uniforms in [0, 1).
vec3 unit_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = TWO_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// A standard normal (mean 0, deviation 1) by Box-Muller, from two uniforms in [0, 1).
float gaussian(vec2 u) { return sqrt(-2.0 * log(max(u.x, 1e-12))) * cos(TWO_PI * u.y); }

// ---------------------------------------------------------------- small maths

float saturate(float x) { return clamp(x, 0.0, 1.0); }
vec3 saturate(vec3 x) { return clamp(x, 0.0, 1.0); }
float sqr(float x) { return x * x; }
float length2(vec3 v) { return dot(v, v); }

// v / |v|, or `fallback` for a (near) zero vector: no NaN from normalize(vec3(0)).
vec3 safe_normalize(vec3 v, vec3 fallback) {
    float l2 = dot(v, v);
    return l2 > 1e-20 ? v * inversesqrt(l2) : fallback;
}

// Rotate v by the unit quaternion q = (x, y, z, w).
vec3 quat_rotate(vec4 q, vec3 v) {
    vec3 t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}
vec4 quat_mul(vec4 a, vec4 b) {
    return vec4(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}
vec4 quat_conj(vec4 q) { return vec4(-q.xyz, q.w); }

// Any unit vector perpendicular to the unit vector n (Duff et al. 2017, branchless ONB).
void orthonormal_basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Catmull-Rom interpolation between p1 and p2 at t in [0, 1].
vec3 catmull_rom(vec3 p0, vec3 p1, vec3 p2, vec3 p3, float t) {
    float t2 = t * t, t3 = t2 * t;
    return 0.5 * ((2.0 * p1) + (-p0 + p2) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
                  + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t3);
}

// Linear (not sRGB) luminance.
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

#endif  // MANE_COMMON_GLSL
