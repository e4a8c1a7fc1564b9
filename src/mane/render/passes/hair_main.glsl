// The hair fragment shader's body (after the shading model's include).
#include "hair_radiance.glsl"
#include "coverage_mask.glsl"

// centroid: under MSAA a fragment of a strand thinner than a pixel is shaded at a point inside
// the samples it covers, on the strand, not at the pixel's centre extrapolated off it (a shadow
// look-up there reads another fibre's texel; Sintel brown against the path tracer, the hardware
// rasteriser: 0.356 -> 0.345 relative error per pixel, docs/quality.md)
centroid in vec3 g_pos;
centroid in vec3 g_tangent;
centroid in float g_s;
in float g_rand;
in float g_alpha;
centroid in float g_depth;
#if HAIR_NEAR_FIELD
centroid in float g_across;    // the near field's h (hair_shading.glsl's hair_set_near)
in float g_width_px;
#endif
flat in int g_strand;          // the rendered strand (coverage_mask.glsl)

uniform vec3 u_eye;
uniform sampler2D u_dom_depth;   // PASS 2: z0 of the hair (m)
uniform vec3 u_dom_layers_abs;   // PASS 3: layer ends after z0 (m)
uniform float u_strand_opacity;
// SAMPLE_MASK (hair_pass.py): 0 premultiplied blending (alpha = coverage); 1 MSAA, the coverage
// as a sample mask (coverage_mask.glsl). A define, not a uniform: a CPU rasteriser runs both
// sides of a branch for every fragment (the mask's hashes cost llvmpipe's hair pass ~20%).
#ifndef SAMPLE_MASK
#define SAMPLE_MASK 0
#endif

#if PASS == 0
layout(location = 0) out vec4 frag;
#if MS_SPLIT   // the multiply scattered light to its own target (passes/ms_smooth.py), as frag's colour
layout(location = 1) out vec4 frag_ms;
#endif
#elif PASS == 1 || PASS == 2
layout(location = 0) out float frag_depth;
#else
layout(location = 0) out vec4 frag_opacity;
#endif

void main() {
#if PASS == 0
#if HAIR_NEAR_FIELD
    // the near field's window is the pixel (its centre, not the covered samples' centroid: the
    // windows of a fibre's pixels then tile its width)
    hair_set_near(interpolateAtOffset(g_across, vec2(0.0)), g_width_px);
#endif
    vec3 color = hair_radiance(g_pos, normalize(g_tangent), u_eye, g_s, g_rand);
#if SAMPLE_MASK   // MSAA: each sample covered with probability g_alpha, covered samples opaque
    gl_SampleMask[0] = coverage_mask(g_alpha, g_strand, ivec2(gl_FragCoord.xy));
    frag = vec4(color, 1.0);
#if MS_SPLIT
    frag_ms = vec4(g_hair_ms, 1.0);
#endif
#else
    frag = vec4(color * g_alpha, g_alpha);
#if MS_SPLIT
    frag_ms = vec4(g_hair_ms * g_alpha, g_alpha);
#endif
#endif
#elif PASS == 1 || PASS == 2
    // light depth (shadow map, deep opacity z0)
    frag_depth = g_depth;
#else
    // deep opacity layers: add to this fragment's layer and all behind it
    float z0 = texelFetch(u_dom_depth, ivec2(gl_FragCoord.xy), 0).r;
    float dz = g_depth - z0;
    float a = u_strand_opacity * g_alpha;
    vec3 add = vec3(dz < u_dom_layers_abs.x ? a : 0.0, dz < u_dom_layers_abs.y ? a : 0.0, a);
    frag_opacity = vec4(add, 0.0);
#endif
}
