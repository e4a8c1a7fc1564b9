#version 430
// Random subsets resolve: the nearest fragment of each of the OIT_K subsets, sorted by key
// and blended front to back.
#include "oit_common.glsl"

uniform ivec2 u_oit_size;
layout(std430, binding = B_OIT_KEYS) readonly buffer OitKeys { uint oit_keys[]; };
layout(std430, binding = B_OIT_COLORS) readonly buffer OitColors { uvec2 oit_colors[]; };
layout(location = 0) out vec4 frag;

void main() {
    ivec2 xy = ivec2(gl_FragCoord.xy);
    int P = u_oit_size.x * u_oit_size.y;
    int p = xy.y * u_oit_size.x + xy.x;
    uint keys[OIT_K];
    uvec2 cols[OIT_K];
    int n = 0;
    // fixed trip counts only (llvmpipe mis-runs data-dependent loops after / inside others)
    for (int s = 0; s < OIT_K; ++s) {
        uint k = oit_keys[s * P + p];
        keys[s] = k;
        cols[s] = k == OIT_END ? uvec2(0u) : oit_colors[s * P + p];
        if (k != OIT_END) ++n;
    }
    for (int a = 1; a < OIT_K; ++a) {        // insertion sort by odd-even passes: K x K fixed
        for (int b = OIT_K - 1; b > 0; --b) {
            if (keys[b] < keys[b - 1]) {
                uint tk = keys[b]; keys[b] = keys[b - 1]; keys[b - 1] = tk;
                uvec2 tc = cols[b]; cols[b] = cols[b - 1]; cols[b - 1] = tc;
            }
        }
    }
    if (n == 0) discard;
    vec3 C = vec3(0.0);
    float T = 1.0;
    for (int i = 0; i < OIT_K; ++i)
        if (keys[i] != OIT_END) oit_blend(C, T, oit_unpack(cols[i]));
    frag = vec4(C, 1.0 - T);
}
