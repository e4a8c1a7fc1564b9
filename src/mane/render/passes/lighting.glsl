// Lights (light 0 casts the shadows) and shadow look-ups shared by the hair and the head.
#define MAX_LIGHTS 3
uniform int u_num_lights;
uniform vec4 u_light_vec[MAX_LIGHTS];        // xyz: direction toward the light (w = 0) or position (w = 1)
uniform vec3 u_light_radiance[MAX_LIGHTS];   // colour * intensity
uniform vec3 u_ambient;

// SHADOWS: 0 none, 1 shadow map (linear light depth, PCF), 2 deep opacity map (+ the head's map)
uniform mat4 u_light_view_proj;
uniform vec3 u_light_eye;
uniform vec3 u_light_dir;                    // unit forward of the light's view
uniform sampler2D u_shadow_map;              // R32F: nearest light depth (m)
uniform sampler2D u_dom;                     // RGBA32F: opacity layers 1..3, z0 (m)
uniform vec3 u_dom_layers;                   // layer ends after z0 (m)
uniform float u_shadow_bias;                 // m
uniform float u_shadow_density;
uniform int u_pcf;

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
    vec4 c = u_light_view_proj * vec4(P, 1.0);
    vec2 uv = c.xy / c.w * 0.5 + 0.5;
    return vec3(uv, dot(P - u_light_eye, u_light_dir));
}

float shadow_map_visibility(vec3 P) {
    vec3 q = light_uvz(P);
    ivec2 size = textureSize(u_shadow_map, 0);
    vec2 texel = q.xy * vec2(size) - 0.5;
    ivec2 c = ivec2(floor(texel + 0.5));
    int r = u_pcf / 2;
    int lo = -r, hi = u_pcf - 1 - r;
    float lit = 0.0, n = 0.0;
    for (int y = lo; y <= hi; ++y)
        for (int x = lo; x <= hi; ++x) {
            ivec2 t = clamp(c + ivec2(x, y), ivec2(0), size - 1);
            float z = texelFetch(u_shadow_map, t, 0).r;
            lit += (q.z - u_shadow_bias <= z) ? 1.0 : 0.0;
            n += 1.0;
        }
    return lit / n;
}

// Opacity in front of depth z, from one deep-opacity texel: piecewise linear through
// (z0, 0), (z0 + d1, O1), (z0 + d2, O2), (z0 + d3, O3), constant beyond.
float dom_opacity(vec4 t, float z) {
    float dz = z - t.a;
    if (dz <= 0.0) return 0.0;
    if (dz < u_dom_layers.x) return t.r * dz / u_dom_layers.x;
    if (dz < u_dom_layers.y) return mix(t.r, t.g, (dz - u_dom_layers.x) / (u_dom_layers.y - u_dom_layers.x));
    if (dz < u_dom_layers.z) return mix(t.g, t.b, (dz - u_dom_layers.y) / (u_dom_layers.z - u_dom_layers.y));
    return t.b;
}

float dom_transmittance(vec3 P) {
    vec3 q = light_uvz(P);
    ivec2 size = textureSize(u_dom, 0);
    ivec2 c = ivec2(floor(q.xy * vec2(size)));
    int r = u_pcf / 2;
    int lo = -r, hi = u_pcf - 1 - r;
    float tr = 0.0, n = 0.0;
    for (int y = lo; y <= hi; ++y)
        for (int x = lo; x <= hi; ++x) {
            ivec2 t = clamp(c + ivec2(x, y), ivec2(0), size - 1);
            tr += exp(-u_shadow_density * dom_opacity(texelFetch(u_dom, t, 0), q.z));
            n += 1.0;
        }
    return tr / n;
}

// Fraction of light 0 that reaches P.
float light0_visibility(vec3 P) {
#if SHADOWS == 1
    return shadow_map_visibility(P);
#elif SHADOWS == 2
    return dom_transmittance(P) * shadow_map_visibility(P);
#else
    return 1.0;
#endif
}
