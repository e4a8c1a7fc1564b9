// Lights (light 0 casts the shadows) and shadow look-ups shared by the hair and the head.
#define MAX_LIGHTS 4
uniform int u_num_lights;
uniform vec4 u_light_vec[MAX_LIGHTS];        // xyz: direction toward the light (w = 0) or position (w = 1)
uniform vec3 u_light_radiance[MAX_LIGHTS];   // colour * intensity
uniform vec3 u_ambient;

// SHADOWS: 0 none, 1 shadow map (linear light depth, PCF), 2 deep opacity map (+ the head's map),
// 3 ADSM, 4 opacity shadow maps, 5 density ray march (each + the head's map)
uniform mat4 u_light_view_proj;
uniform vec3 u_light_eye;
uniform vec3 u_light_dir;                    // unit forward of the light's view
uniform sampler2D u_shadow_map;              // R32F: nearest light depth (m)
uniform sampler2D u_dom;                     // RGBA32F: opacity layers 1..3, z0 (m)
uniform vec3 u_dom_layers;                   // layer ends after z0 (m)
uniform float u_shadow_bias;                 // m
uniform float u_shadow_texel;                // m: the world size of a texel of light 0's maps
uniform float u_normal_offset;               // surface receivers: normal offset (texels, settings)
uniform float u_slope_bias;                  // surface receivers: depth bias per unit tan(N, L) (texels)
float g_receiver_bias = 0.0;                 // m: more depth bias for the receiver being shaded
uniform float u_shadow_density;
// PCF: the look-ups' PCF kernel (settings pcf, head_pcf; shadow_defines), a compile-time
// constant: its loops unroll (on llvmpipe a loop to a uniform bound cost the head pass more than
// twice its shading)
#ifndef PCF
#if SHADOWS != 0
#error "PCF (the PCF kernel) is not defined: passes/base.py shadow_defines"
#endif
#define PCF 1
#endif
// MS_FOOTPRINT: texels of u_dom the multiple scattering's look-up averages over
// (settings.ms_shadow_footprint; shadow_defines), 0: off
#ifndef MS_FOOTPRINT
#define MS_FOOTPRINT 0
#endif

#include "shadow_pcf.glsl"

vec3 light_dir_at(int i, vec3 P, out float falloff) {
    vec4 l = u_light_vec[i];
    if (l.w > 0.5) {
        vec3 d = l.xyz - P;
        float d2 = max(dot(d, d), 1e-6);
        falloff = 1.0 / d2;
        return d * inversesqrt(d2);
    }
    falloff = 1.0;
    return normalize(l.xyz);
}

vec3 light_uvz(vec3 P) {
    return light_space(u_light_view_proj, u_light_eye, u_light_dir, P);
}

float shadow_map_visibility(vec3 P) {
    vec3 q = light_uvz(P);
    return pcf_compare(u_shadow_map, q.xy * vec2(textureSize(u_shadow_map, 0)) - 0.5,
                       q.z - u_shadow_bias - g_receiver_bias);
}

// Opacity in front of depth z, from one deep-opacity texel: piecewise linear through
// (z0, 0), (z0 + d1, O1), (z0 + d2, O2), (z0 + d3, O3), constant beyond (layer ends d1..d3).
float dom_opacity(vec4 t, float z, vec3 layers) {
    float dz = z - t.a;
    if (dz <= 0.0) return 0.0;
    if (dz < layers.x) return t.r * dz / layers.x;
    if (dz < layers.y) return mix(t.r, t.g, (dz - layers.x) / (layers.y - layers.x));
    if (dz < layers.z) return mix(t.g, t.b, (dz - layers.y) / (layers.z - layers.y));
    return t.b;
}

float dom_transmittance(vec3 P) {
    vec3 q = light_uvz(P);
    ivec2 size = textureSize(u_dom, 0);
    float tr;
    // each texel's transmittance at P's depth (its own z0 and layers), interpolated between
    // texels: no texel blocks where z0 or the layers jump from one texel to the next
    PCF_BILINEAR(tr, q.xy * vec2(size) - 0.5, size, t,
                 exp(-u_shadow_density * dom_opacity(texelFetch(u_dom, t, 0), q.z, u_dom_layers)))
    return tr;
}

// SHADOWS 3 (ADSM), 4 (opacity shadow maps), 5 (density ray march): one look-up per file.
#include "shadow_adsm.glsl"
#include "shadow_osm.glsl"
#include "shadow_density.glsl"

// Fraction of light 0 that reaches P.
float light0_visibility(vec3 P) {
#if SHADOWS == 1
    return shadow_map_visibility(P);
#elif SHADOWS == 2
    return dom_transmittance(P) * shadow_map_visibility(P);
#elif SHADOWS == 3
    return adsm_transmittance(P) * shadow_map_visibility(P);
#elif SHADOWS == 4
    return osm_transmittance(P) * shadow_map_visibility(P);
#elif SHADOWS == 5
    return density_transmittance(P) * shadow_map_visibility(P);
#else
    return 1.0;
#endif
}

// ---------------------------------------------------------------- more shadow-casting lights
// Lights 1 .. u_num_shadow_lights-1 cast shadows too (light 0 is above): each has its own
// shadow map (head and hair depth, PCF; with SHADOWS 2 the head only) and, with SHADOWS 2, its
// own deep opacity map (coarser: settings.extra_shadow_map_size). With SHADOWS 3..5 those
// lights use the shadow map. Index 0 unused.
#define MAX_SHADOW_LIGHTS 4
uniform int u_num_shadow_lights;
uniform mat4 u_xlight_view_proj[MAX_SHADOW_LIGHTS];
uniform vec3 u_xlight_eye[MAX_SHADOW_LIGHTS];
uniform vec3 u_xlight_dir[MAX_SHADOW_LIGHTS];
uniform float u_xshadow_bias[MAX_SHADOW_LIGHTS];
uniform float u_xshadow_texel[MAX_SHADOW_LIGHTS];
uniform vec3 u_xdom_layers[MAX_SHADOW_LIGHTS];
uniform sampler2D u_xshadow_map[MAX_SHADOW_LIGHTS];
uniform sampler2D u_xdom[MAX_SHADOW_LIGHTS];

// The maps come in as arguments. XLIGHT_CONST 1 (CPU rasterisers, passes/base.py's
// shadow_defines): each sampler array indexed by a constant, the look-up inlined once per light:
// llvmpipe's compute shaders indexing the sampler arrays by the light's variable index lost other
// samplers' look-ups (the hair's multiply scattered light went missing, with one light too).
// XLIGHT_CONST 0 (GPUs): indexed by the light, dynamically uniform as GLSL 4.3 asks, one copy of
// the look-up (the H200's 100k close-up: the shading pass 0.04 ms faster than with three).
#ifndef XLIGHT_CONST
#define XLIGHT_CONST 1
#endif
float xlight_visibility(int i, vec3 P, sampler2D shadow_map, sampler2D dom) {
    vec3 q = light_space(u_xlight_view_proj[i], u_xlight_eye[i], u_xlight_dir[i], P);
    ivec2 size = textureSize(shadow_map, 0);
    vec2 x = q.xy * vec2(size) - 0.5;
    float tr = 1.0;
    float lit = pcf_compare(shadow_map, x, q.z - u_xshadow_bias[i] - g_receiver_bias);
#if SHADOWS == 2
    PCF_BILINEAR(tr, x, size, t, exp(-u_shadow_density * dom_opacity(texelFetch(dom, t, 0), q.z, u_xdom_layers[i])))
#endif
    return lit * tr;
}

// Fraction of light i that reaches P (1 for lights that cast no shadow). XSHADOWS 0 (one
// shadow-casting light, settings.shadow_lights = 1) compiles the other lights' look-ups out.
#ifndef XSHADOWS
#define XSHADOWS 1
#endif
float light_visibility(int i, vec3 P) {
    if (i == 0) return light0_visibility(P);
#if SHADOWS != 0 && XSHADOWS
    if (i < u_num_shadow_lights) {
#if XLIGHT_CONST
        if (i == 1) return xlight_visibility(1, P, u_xshadow_map[1], u_xdom[1]);
        if (i == 2) return xlight_visibility(2, P, u_xshadow_map[2], u_xdom[2]);
        if (i == 3) return xlight_visibility(3, P, u_xshadow_map[3], u_xdom[3]);
#else
        return xlight_visibility(i, P, u_xshadow_map[i], u_xdom[i]);
#endif
    }
#endif
    return 1.0;
}

// (direct, multiple scattering, behind) of light 0 at P. With deep opacity maps and
// MS_FOOTPRINT > 0 (settings.ms_shadow_footprint) the multiple-scattering term sees the deep
// opacity map's transmittance averaged over a MS_FOOTPRINT x MS_FOOTPRINT texel box (PCF_BOX),
// the direct light the PCF box's (the shadow map looked up once for both): a fibre-resolving map
// (1024^2, strand_opacity 0.7, pcf 1) gives the direct light its strand-resolved shadows while
// the dual-scattering term (its fibre count n = -log t, the forward-scattered T_f) stays the
// light's mean over a wider footprint (Zinke et al. 2008: directFraction per fibre, the global
// term smooth). "behind" is the share of that light which meets hair beyond P, away from the
// light: 1 - T_total / t, T_total the same box's transmittance through the whole column (the
// map's last layer). Zinke's terms hold inside a volume of hair; where little hair lies beyond
// a point (the tips, the far side) the light scattered there mostly leaves it, and the
// multiple scattering is scaled by "behind" (hair_radiance.glsl; docs/quality.md). MS_FOOTPRINT
// 0: the box is the direct light's (PCF), the same transmittance for both. Other methods: both
// are light0_visibility and behind is 1. Costs (MS_BOX + 1)^2 more texel fetches and
// dom_opacity calls.
#if MS_FOOTPRINT > 0
#define MS_BOX MS_FOOTPRINT
#else
#define MS_BOX PCF
#endif
vec3 light0_visibility_ms(vec3 P) {
#if SHADOWS == 2
    vec3 q = light_uvz(P);
    ivec2 size = textureSize(u_dom, 0);
    vec2 ms;   // (at P's depth, through the whole column)
    vec4 texel;
    PCF_BOX2(ms, q.xy * vec2(size) - 0.5, size, t, MS_BOX,
             (texel = texelFetch(u_dom, t, 0),
              exp(-u_shadow_density * vec2(dom_opacity(texel, q.z, u_dom_layers), texel.b))))
    float behind = 1.0 - min(ms.y / max(ms.x, 1e-30), 1.0);
    return vec3(vec2(dom_transmittance(P), ms.x) * shadow_map_visibility(P), behind);
#else
    return vec3(vec2(light0_visibility(P)), 1.0);
#endif
}

// The same for a point on a surface with unit normal N (the head), L toward light i: a surface
// seen by the light at a grazing angle changes depth by tan(N, L) texels per texel, so a
// constant bias lets it shadow itself in terraces (acne) and rings, the more so under the PCF
// box. The look-up point moves off the surface along N by u_normal_offset texels times
// sin(N, L) (normal offset; the full offset on the side facing away, where wrap lighting still
// lights it), and the depth bias grows by u_slope_bias texels per unit tan(N, L), up to 10.
float surface_light_visibility(int i, vec3 P, vec3 N, vec3 L) {
    float c = dot(N, L);
    float s = c > 0.0 ? sqrt(max(1.0 - c * c, 0.0)) : 1.0;
    float tan_nl = min(s / max(c, 0.1), 10.0);
#if SHADOWS != 0 && XSHADOWS
    float texel = i == 0 ? u_shadow_texel : u_xshadow_texel[min(i, MAX_SHADOW_LIGHTS - 1)];
#else
    float texel = u_shadow_texel;
#endif
    g_receiver_bias = u_slope_bias * texel * tan_nl;
    float v = light_visibility(i, P + N * (u_normal_offset * texel * s));
    g_receiver_bias = 0.0;
    return v;
}

// Every light's visibility (1 past u_num_lights and for lights that cast no shadow), computed
// before the shading's loop over the lights: inside it (the light's index not a constant) a CPU
// rasteriser ran light 0's look-up for every light (llvmpipe, docs/quality.md). At a point in
// the hair, and at a point on a surface with unit normal N (surface_light_visibility). The
// hair looks up per fragment or, with VERTEX_SHADOWS (settings.hair_shadow_lookup
// "vertex"), at its points, the fragments interpolating.
#if SHADOWS != 0 && XSHADOWS
#define SHADOW_CASTERS MAX_SHADOW_LIGHTS
#else
#define SHADOW_CASTERS 1
#endif
// Lights from `first` on (1 for the lights before it).
vec4 light_visibilities_from(int first, vec3 P) {
    vec4 vis = vec4(1.0);
#if SHADOWS != 0
    for (int i = first; i < SHADOW_CASTERS; ++i)
        if (i < u_num_lights) vis[i] = light_visibility(i, P);
#endif
    return vis;
}

vec4 light_visibilities(vec3 P) {
    return light_visibilities_from(0, P);
}

vec4 surface_light_visibilities(vec3 P, vec3 N) {
    vec4 vis = vec4(1.0);
#if SHADOWS != 0
    for (int i = 0; i < SHADOW_CASTERS; ++i) {
        if (i < u_num_lights) {
            float falloff;
            vis[i] = surface_light_visibility(i, P, N, light_dir_at(i, P, falloff));
        }
    }
#endif
    return vis;
}
