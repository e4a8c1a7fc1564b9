#version 430
// K-buffer resolve: the K slots (ascending) blended front to back, then the tail (the
// fragments pushed out: alpha-weighted mean colour with their total transmittance) behind.
#include "oit_common.glsl"

uniform ivec2 u_oit_size;
uniform sampler2D u_oit_tail;         // rgb: sum of premultiplied colours, a: prod(1 - alpha)
uniform sampler2D u_oit_tail_alpha;   // r: sum of alphas
#if OIT_KBUF_MODE == 0
layout(std430, binding = B_OIT_KEYS) readonly buffer OitKeys { uint oit_keys[]; };
layout(std430, binding = B_OIT_COLORS) readonly buffer OitColors { uvec2 oit_colors[]; };
#elif OIT_KBUF_MODE == 1
layout(std430, binding = B_OIT_KEYS) readonly buffer OitKeys64 { uvec2 oit_keys64[]; };   // (low, high) words
#else
layout(std430, binding = B_OIT_KEYS) readonly buffer OitDepths { float oit_depths[]; };
layout(std430, binding = B_OIT_COLORS) readonly buffer OitColors { uvec2 oit_colors[]; };
#endif
layout(location = 0) out vec4 frag;

void main() {
    ivec2 xy = ivec2(gl_FragCoord.xy);
    int P = u_oit_size.x * u_oit_size.y;
    int p = xy.y * u_oit_size.x + xy.x;
    vec3 C = vec3(0.0);
    float T = 1.0;
    for (int i = 0; i < OIT_K; ++i) {
#if OIT_KBUF_MODE == 0
        if (oit_keys[i * P + p] != OIT_END)
            oit_blend(C, T, oit_unpack(oit_colors[i * P + p]));
#elif OIT_KBUF_MODE == 1
        uvec2 w = oit_keys64[i * P + p];
        if (!(w.x == OIT_END && w.y == OIT_END))
            oit_blend(C, T, oit_unpack40(uvec2(w.x, w.y & 255u)));
#else
        if (oit_depths[i * P + p] < 3.0e38)
            oit_blend(C, T, oit_unpack(oit_colors[i * P + p]));
#endif
    }
    vec4 tail = texelFetch(u_oit_tail, xy, 0);
    float asum = texelFetch(u_oit_tail_alpha, xy, 0).r;
    float tT = clamp(tail.a, 0.0, 1.0);
    if (asum > 1e-6) {
        C += T * tail.rgb / asum * (1.0 - tT);
        T *= tT;
    }
    frag = vec4(C, 1.0 - T);
}
