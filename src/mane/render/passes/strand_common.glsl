// Guide strands on the GPU: every guide has u_n points; point k of guide g is positions[g*u_n + k]
// (the simulator's layout: xyz metres, w inverse mass). frames[] holds, per point, a unit normal
// of the guide's parallel-transported frame (xyz).
layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_FRAMES) readonly buffer Frames { vec4 frames[]; };

uniform int u_n;                  // points per guide
uniform int u_num_guides;
uniform int u_strands_per_guide;  // rendered strands per guide
uniform int u_subdivisions;       // tessellated segments per guide segment (<= 64)

vec3 guide_point(int g, int k) {
    // phantom end points: mirror the neighbour through the root / tip
    int base = g * u_n;
    if (k < 0) return 2.0 * positions[base].xyz - positions[base + 1].xyz;
    if (k >= u_n) return 2.0 * positions[base + u_n - 1].xyz - positions[base + u_n - 2].xyz;
    return positions[base + k].xyz;
}

vec3 guide_normal(int g, int k) {
    return frames[g * u_n + clamp(k, 0, u_n - 1)].xyz;
}

// ---------------------------------------------------------------- hashing (stable per strand)
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
uint strand_seed(int guide, int strand) {
    return pcg_hash(uint(guide) * 9781u + pcg_hash(uint(strand) + 0x9e3779b9u));
}
float rand01(inout uint seed) {
    seed = pcg_hash(seed);
    return float(seed >> 8) * (1.0 / 16777216.0);
}

// ---------------------------------------------------------------- curve schemes
// u in [0,1] on the segment P1 -> P2; P0 and P3 are the neighbours.
void eval_curve(vec3 P0, vec3 P1, vec3 P2, vec3 P3, float u, out vec3 pos, out vec3 deriv) {
#if INTERPOLATION == 0
    // Catmull-Rom (Woodhouse): a u^3 + b u^2 + c u + d
    vec3 a = -0.5 * P0 + 1.5 * P1 - 1.5 * P2 + 0.5 * P3;
    vec3 b = P0 - 2.5 * P1 + 2.0 * P2 - 0.5 * P3;
    vec3 c = -0.5 * P0 + 0.5 * P2;
    pos = ((a * u + b) * u + c) * u + P1;
    deriv = (3.0 * a * u + 2.0 * b) * u + c;
#elif INTERPOLATION == 1
    // uniform cubic B-spline (Chen)
    float v = 1.0 - u;
    float b0 = v * v * v / 6.0;
    float b1 = (3.0 * u * u * u - 6.0 * u * u + 4.0) / 6.0;
    float b2 = (-3.0 * u * u * u + 3.0 * u * u + 3.0 * u + 1.0) / 6.0;
    float b3 = u * u * u / 6.0;
    pos = b0 * P0 + b1 * P1 + b2 * P2 + b3 * P3;
    deriv = (-0.5 * v * v) * P0 + (1.5 * u * u - 2.0 * u) * P1
          + (-1.5 * u * u + u + 0.5) * P2 + (0.5 * u * u) * P3;
#else
    // cubic Bezier per segment (Vulkan hair): inner control points from the neighbours so that
    // consecutive segments share the tangent (P2 - P0)/2 at their joint: C1. De Casteljau.
    vec3 c0 = P1, c1 = P1 + (P2 - P0) / 6.0, c2 = P2 - (P3 - P1) / 6.0, c3 = P2;
    vec3 d0 = mix(c0, c1, u), d1 = mix(c1, c2, u), d2 = mix(c2, c3, u);
    vec3 e0 = mix(d0, d1, u), e1 = mix(d1, d2, u);
    pos = mix(e0, e1, u);
    deriv = 3.0 * (e1 - e0);
#endif
}

// ---------------------------------------------------------------- multi-strand interpolation (MULTI 1, hybrid 2)
// One record per rendered strand: 3 guides (w: flags, bit 0 = hybrid single-strand fallback),
// barycentric weights (the heaviest guide first) and a root offset (m, world).
#ifndef MULTI
#define MULTI 0
#endif
#ifndef LOD
#define LOD 0
#endif
struct StrandRecord { ivec4 guides; vec4 weights; vec4 offset; };
#if MULTI
layout(std430, binding = B_STRAND_TABLE) readonly buffer StrandTable { StrandRecord strand_table[]; };
#endif
uniform int u_num_render;         // MULTI: rendered strands (records)

// ---------------------------------------------------------------- distance LOD
uniform vec3 u_lod_eye;           // the camera's eye (every pass: the shadows see the same hair)
uniform vec4 u_lod_range;         // start, end (m), density at end, width multiplier at end
uniform vec2 u_lod_segments;      // segment fraction at end, fewest segments per strand
uniform int u_segments;           // settings.segments

float lod_t(vec3 root) {
#if LOD
    float d = distance(root, u_lod_eye);
    return clamp((d - u_lod_range.x) / max(u_lod_range.y - u_lod_range.x, 1e-6), 0.0, 1.0);
#else
    return 0.0;
#endif
}
