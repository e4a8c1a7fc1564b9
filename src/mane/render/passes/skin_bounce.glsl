// The skin's one-bounce light on the hair (settings.skin_bounce; skin_bounce.py): light 0's
// light reflected once by the head's Lambertian skin, gathered from a reflective shadow map
// (Dachsbacher and Stamminger 2005) of the head seen from light 0.
//
// The map (skin_rsm.frag), u_rsm_size^2 texels over light 0's view, mipmapped (2 x 2 means):
//   u_rsm_flux: rgb B = albedo * E_perp * visibility, the flux the skin reflects per unit area
//               of the light's view (E_perp: the light's irradiance normal to it; the skin's
//               own N.L cancels against its area per texel, A_perp / N.L), 0 where the light
//               does not reach the skin (N.L <= 0); a: the head's coverage of the texel
//   u_rsm_geom: xyz the skin's unit normal, w its linear light depth (m), both times the coverage
// A texel of a mip level is a Lambertian patch of flux B * A: radiant intensity
// I(w) = B A max(0, n.w) / pi. Per shaded point x, SKIN_BOUNCE_SAMPLES fixed samples k
// (u_rsm_samples[k] = (du, dv, A_k, lod_k): offsets in the map's uv around x's projection on a
// golden-angle spiral of radius R, denser toward x (r_k = R (k + 1/2) / N), A_k the light-view
// area (m^2) the sample stands for, lod_k the mip level whose texel is about sqrt(A_k) wide) each
// add their patch's fluence (radiance over the sphere of directions, no receiver cosine: a fibre
// has none)
//     phi += 2 B_k cos_k (1 - d_k / sqrt(d_k^2 + a_k^2)),   a_k^2 = A_k / pi,
// cos_k = max(0, n_k . (x - p_k)) / d_k: the fluence of a Lambertian disc of radiance B_k / pi and
// area A_k on its axis at d_k, times the cosine off its axis; far away it is the point source's
// B_k A_k cos_k / (pi d_k^2), close it stays finite (2 B_k: a hemisphere). Computed as
// 2 B cos a^2 / (r (r + d)), r = sqrt(d^2 + a^2) (no cancellation far away).
// Every skin point within R of x (in the light's view plane) is gathered; past R the field is
// weak (1 / d^2) and left out. The fibre scatters that light as it scatters isotropic light of
// the same fluence (hair_isotropic_albedo, the multiple-scattering term's diffuse response):
//     L_bounce = u_skin_bounce * albedo(theta_o) * phi / (4 pi)
// skin_bounce.py's gather_numpy is this function's twin (tests/test_render_skin_bounce.py).
// Needs lighting.glsl (the deep opacity map's uniforms and dom_opacity). The gather runs at the
// cells of the grid (skin_bounce_grid.comp) that the shaded points read (skin_bounce_grid below),
// or with base.SKIN_BOUNCE_GRID False at every shaded point.
#include "common.glsl"
#include "lighting.glsl"
#ifndef SKIN_BOUNCE_SAMPLES
#define SKIN_BOUNCE_SAMPLES 16
#endif
uniform sampler2D u_rsm_flux;
uniform sampler2D u_rsm_geom;
uniform mat4 u_rsm_view_proj;        // light 0's view (the map's)
uniform mat4 u_rsm_inv_view_proj;
uniform vec3 u_rsm_eye;
uniform vec3 u_rsm_dir;
uniform vec4 u_rsm_samples[SKIN_BOUNCE_SAMPLES];
uniform float u_skin_bounce;         // settings.skin_bounce
uniform sampler2D u_rsm_dom;         // SHADOWS 2: the deep opacity map's (z0, O1, O2, O3) in the skin's column

// The point of light 0's view at map coordinates uv and linear light depth z.
vec3 rsm_point(vec2 uv, float z) {
    vec2 ndc = uv * 2.0 - 1.0;
    vec4 a = u_rsm_inv_view_proj * vec4(ndc, -1.0, 1.0);
    vec4 b = u_rsm_inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 A = a.xyz / a.w, B = b.xyz / b.w;
    float za = dot(A - u_rsm_eye, u_rsm_dir), zb = dot(B - u_rsm_eye, u_rsm_dir);
    return A + (B - A) * ((z - za) / (zb - za));
}

// The skin's reflected light's fluence at x (W / m^2 over the sphere: 4 pi times the mean radiance).
vec3 skin_bounce_fluence(vec3 x) {
    vec4 c = u_rsm_view_proj * vec4(x, 1.0);
    vec2 uv0 = c.xy / c.w * 0.5 + 0.5;
    float zx = dot(x - u_rsm_eye, u_rsm_dir);
    vec3 phi = vec3(0.0);
    for (int k = 0; k < SKIN_BOUNCE_SAMPLES; ++k) {
        vec4 s = u_rsm_samples[k];
        vec2 uv = uv0 + s.xy;
        vec4 f = textureLod(u_rsm_flux, uv, s.w);
        if (f.a < 1e-4) continue;
        vec4 g = textureLod(u_rsm_geom, uv, s.w);
        vec3 p = rsm_point(uv, g.w / f.a);
        vec3 w = x - p;
        float d2 = max(dot(w, w), 1e-12);
        float d = sqrt(d2);
        float e = max(dot(g.xyz / f.a, w), 0.0) / d;   // the mean normal's cosine toward x
        float tr = 1.0;
#if SHADOWS == 2
        // the hair in the skin's column between the skin and x's light depth: the bounce toward
        // x crosses it (exactly so for x above the skin, toward the light; for x beside it, the
        // hair between at x's depth is not in this column and is not counted)
        vec4 o = textureLod(u_rsm_dom, uv, s.w) / f.a;
        float zs = g.w / f.a;
        tr = exp(-u_shadow_density * max(dom_opacity(o, zs, u_dom_layers) - dom_opacity(o, min(zx, zs), u_dom_layers), 0.0));
#endif
        float a2 = s.z * INV_PI;
        float r = sqrt(d2 + a2);
        phi += f.rgb * (2.0 * tr * e * a2 / (r * (r + d)));
    }
    return phi;
}

// SKIN_BOUNCE_GRID (base.SKIN_BOUNCE_GRID): skin_bounce_fluence evaluated once a frame at the centres of
// a grid in light 0's space (skin_bounce_grid.comp: u, v over the hair's footprint in the map, w
// its light depth range) and read here once, trilinear; a point outside the grid gets its border
// cells' value (clamp to edge).
uniform vec3 u_bounce_grid_lo;       // the grid's first corner in (u, v, light depth)
uniform vec3 u_bounce_grid_inv;      // 1 / its extent
#if SKIN_BOUNCE_GRID
uniform sampler3D u_bounce_grid;

vec3 skin_bounce_grid(vec3 x) {
    vec4 c = u_rsm_view_proj * vec4(x, 1.0);
    vec3 q = vec3(c.xy / c.w * 0.5 + 0.5, dot(x - u_rsm_eye, u_rsm_dir));
    return textureLod(u_bounce_grid, (q - u_bounce_grid_lo) * u_bounce_grid_inv, 0.0).rgb;
}
#endif
