#version 430
// The skin's reflective shadow map (skin_bounce.py, skin_bounce.glsl): the head seen from light
// 0 (head.vert at light 0's view), per texel the flux the Lambertian skin reflects per unit
// area of the light's view and the skin's normal and light depth. The albedo is the head
// pass's (skin, the scalp tinted by scalp_tint); light 0's visibility is the head pass's too
// (the head's shadow map and the hair's maps, normal-offset: surface_light_visibility) but
// without its wrap and highlight: the light reflected diffusely is albedo * E * N.L per unit of
// skin, and a texel holds A_perp / N.L of skin, so B = albedo * E_perp * visibility. With deep
// opacity maps the third target keeps the hair's opacity layers in the skin's column.
#include "lighting.glsl"
in vec3 h_pos;
in vec3 h_normal;
in float h_scalp;
in float h_depth;
uniform vec3 u_skin;
uniform vec3 u_scalp_color;
layout(location = 0) out vec4 out_flux;
layout(location = 1) out vec4 out_geom;
layout(location = 2) out vec4 out_dom;
uniform int u_rsm_dom_box;   // deep opacity texels per map texel (side)
void main() {
    float falloff;
    vec3 L = light_dir_at(0, h_pos, falloff);
    vec3 N = normalize(h_normal);
    if (dot(N, L) < 0.0) N = -N;   // the side the light sees (an open mesh's back faces)
    vec3 albedo = mix(u_skin, u_scalp_color, clamp(h_scalp, 0.0, 1.0));
    float vis = surface_light_visibility(0, h_pos, N, L);
    out_flux = vec4(albedo * u_light_radiance[0] * falloff * vis, 1.0);
    out_geom = vec4(N, h_depth);
    // the hair's deep opacity texel (z0, O1..O3) over the texel's footprint: the hair in the
    // skin's column toward the light, which the gather's bounce crosses (skin_bounce.glsl)
#if SHADOWS == 2
    ivec2 size = textureSize(u_dom, 0);
    ivec2 base = ivec2(floor(light_uvz(h_pos).xy * vec2(size))) - u_rsm_dom_box / 2;
    vec4 sum = vec4(0.0);
    for (int j = 0; j < u_rsm_dom_box; ++j)
        for (int i = 0; i < u_rsm_dom_box; ++i) {
            vec4 t = texelFetch(u_dom, clamp(base + ivec2(i, j), ivec2(0), size - 1), 0);
            sum += vec4(t.rgb, min(t.a, h_depth));   // no hair: z0 FAR, read as at the skin
        }
    out_dom = sum / float(u_rsm_dom_box * u_rsm_dom_box);
#else
    out_dom = vec4(0.0, 0.0, 0.0, h_depth);
#endif
}
