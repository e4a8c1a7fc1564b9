// The light leaving a point of a strand toward the eye: every light's hair BSDF times its
// shadowing, plus multiple scattering and ambient (the shading model's include comes first).
// Shared by the hair fragment shader (hair_main.glsl) and the compute rasteriser's shading
// pass (hair_shade.comp).
// VERTEX_SHADOWS (settings.hair_shadow_lookup "vertex", the hardware rasteriser's shading pass): the
// lights' visibility comes interpolated from the strand's points (g_vis: hair_pull.vert,
// hair.geom) instead of being looked up at P.
#include "lighting.glsl"
#ifndef VERTEX_SHADOWS
#define VERTEX_SHADOWS 0
#endif
#if VERTEX_SHADOWS
in vec4 g_vis;
#endif
// SKIN_BOUNCE (settings.skin_bounce > 0 and a head drawn: base.bounce_defines): light 0's light
// reflected once by the head's skin (skin_bounce.glsl: SKIN_BOUNCE_GRID, the grid's trilinear
// value at P; else the gather at P), scattered as the fibre scatters isotropic light of the same
// fluence (hair_isotropic_albedo). 0: compiled out.
#ifndef SKIN_BOUNCE
#define SKIN_BOUNCE 0
#endif
#if SKIN_BOUNCE
#include "skin_bounce.glsl"
#endif

uniform HairMaterial u_material;
uniform float u_root_darkening;   // settings.root_darkening
// MS_SPLIT (settings.ms_smoothing > 0: passes/ms_smooth.py): the multiply scattered light is
// left out of what hair_radiance returns and kept in g_hair_ms, which the shading pass writes to a
// target of its own for ms_smooth.comp to smooth across the hair.
#ifndef MS_SPLIT
#define MS_SPLIT 0
#endif
#if MS_SPLIT
vec3 g_hair_ms;
#endif

// P: world point, T: unit tangent, s: 0 at the root .. 1 at the tip, rand: the strand's random.
vec3 hair_radiance(vec3 P, vec3 T, vec3 eye, float s, float rand) {
    vec3 V = normalize(eye - P);
    HairMaterial m = u_material;
    m.strand_rand = rand;
    vec3 color = u_ambient * m.color;
#if VERTEX_SHADOWS
    vec4 vis = g_vis;
    vec4 vis_ms = g_vis;
    float behind = 1.0;
#else
    // the multiple scattering's transmittance: the direct light's, except light 0's with deep
    // opacity maps (light0_visibility_ms: the map over the ms_shadow_footprint box, and
    // the share of its light that meets hair beyond P, which scales light 0's multiple scattering)
    vec3 v0 = light0_visibility_ms(P);
    vec4 vis = light_visibilities_from(1, P);
    vec4 vis_ms = vis;
    vis.x = v0.x;
    vis_ms.x = v0.y;
    float behind = v0.z;
#endif
    vec3 ms = vec3(0.0);
    for (int i = 0; i < MAX_LIGHTS; ++i) {
        if (i >= u_num_lights) break;
        float falloff;
        vec3 L = light_dir_at(i, P, falloff);
        vec3 radiance = u_light_radiance[i] * falloff;
        color += radiance * hair_bsdf(T, V, L, m) * vis[i];
        ms += radiance * hair_multiple_scattering(T, V, L, m, vis_ms[i]) * (i == 0 ? behind : 1.0);
    }
    float darkening = 1.0 - u_root_darkening * (1.0 - smoothstep(0.0, 0.25, s));
#if MS_SPLIT
    g_hair_ms = ms * darkening;
#else
    color += ms;
#endif


#if SKIN_BOUNCE
#if SKIN_BOUNCE_GRID
    vec3 bounce = skin_bounce_grid(P);
#else
    vec3 bounce = skin_bounce_fluence(P);
#endif
    color += (u_skin_bounce * 0.25 * INV_PI) * hair_isotropic_albedo(T, V, m) * bounce;
#endif
    // settings.root_darkening: a painted occlusion toward the root (0: none, the default)
    return color * darkening;
}
