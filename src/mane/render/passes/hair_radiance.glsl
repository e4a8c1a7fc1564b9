// The light leaving a point of a strand toward the eye: every light's hair BSDF times its
// shadowing, plus multiple scattering and ambient (the shading model's include comes first).
// Shared by the hair fragment shader (hair_main.glsl) and the compute rasteriser's shading
// pass (hair_shade.comp).
#include "lighting.glsl"

uniform HairMaterial u_material;

// P: world point, T: unit tangent, s: 0 at the root .. 1 at the tip, rand: the strand's random.
vec3 hair_radiance(vec3 P, vec3 T, vec3 eye, float s, float rand) {
    vec3 V = normalize(eye - P);
    HairMaterial m = u_material;
    m.strand_rand = rand;
    vec3 color = u_ambient * m.color;
    for (int i = 0; i < MAX_LIGHTS; ++i) {
        if (i >= u_num_lights) break;
        float falloff;
        vec3 L = light_dir_at(i, P, falloff);
        vec2 vis = light_visibility_ms(i, P);
        vec3 radiance = u_light_radiance[i] * falloff;
        color += radiance * (hair_bsdf(T, V, L, m) * vis.x + hair_multiple_scattering(T, V, L, m, vis.y));
    }
    // darker toward the root: a touch of the occlusion a clump gives itself
    return color * mix(0.55, 1.0, smoothstep(0.0, 0.25, s));
}
