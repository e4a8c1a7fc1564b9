// The head's skin at a point: Lambert with a little wrap, skin albedo, the scalp tinted toward
// the hair colour (scalp: 0 skin .. 1 scalp), light 0 shadowed by the hair (deep opacity) and by
// the head (shadow map), with normal-offset and slope-scaled bias (lighting.glsl's
// surface_light_visibilities), per pixel: looked up at the vertices (as the hair can,
// settings.hair_shadow_lookup) the shadows of the jaw and of single strands on the neck and
// shoulders were lost between the software preset's vertices. Shared by head.frag and
// head_shade.comp.
#include "lighting.glsl"
uniform vec3 u_eye;
uniform vec3 u_skin;
uniform vec3 u_scalp_color;

vec3 head_radiance(vec3 P, vec3 normal, float scalp) {
    vec3 N = normalize(normal);
    vec3 V = normalize(u_eye - P);
    if (dot(N, V) < 0.0) N = -N;
    vec3 albedo = mix(u_skin, u_scalp_color, clamp(scalp, 0.0, 1.0));
    vec3 color = u_ambient * albedo;
    vec4 vis = surface_light_visibilities(P, N);
    for (int i = 0; i < MAX_LIGHTS; ++i) {
        if (i >= u_num_lights) break;
        float falloff;
        vec3 L = light_dir_at(i, P, falloff);
        float ndl = max(0.0, (dot(N, L) + 0.15) / 1.15);    // a little wrap for skin
        vec3 H = normalize(L + V);
        float spec = 0.04 * pow(max(dot(N, H), 0.0), 24.0);
        color += u_light_radiance[i] * falloff * vis[i] * (albedo * ndl / 3.14159265 + spec * ndl);
    }
    return color;
}
