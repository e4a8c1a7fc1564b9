// Marschner 2003 from lookup textures (Nguyen and Donnelly 2005 layout, Hunz Algorithm 2):
// the tables are built in NumPy by luts.build_marschner_luts (layout, resolution and format
// in luts.py: M RGBA16F size^2 over (sin theta_i, sin theta_o) with cos theta_i/cos^2 theta_d
// baked in and A = cos theta_d; N RGBA16F (2 size) x size over (cos phi, cos theta_d), left
// tile N_TT + N_R, right tile N_TRT). They bake sigma_a, eta, roughness, shift, glint and the
// caustic constants: u_material only contributes `specular` here (ShadingSettings.bind()
// rebuilds and caches the tables per material).
// ALU: 2 dot, 1 inversesqrt, ~25 mul/add, 3 bilinear fetches (~35 + 3 tex).
#ifndef MANE_HAIR_MARSCHNER_LUT_GLSL
#define MANE_HAIR_MARSCHNER_LUT_GLSL
#if HAIR_MODEL == HAIR_MODEL_MARSCHNER_LUT

uniform sampler2D hair_lut_m;
uniform sampler2D hair_lut_n;

vec3 hair_marschner_lut(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    float si = clamp(dot(T, L), -1.0, 1.0);
    float so = clamp(dot(T, V), -1.0, 1.0);
    vec2 sm = vec2(textureSize(hair_lut_m, 0));
    vec4 M = texture(hair_lut_m, ((vec2(si, so) * 0.5 + 0.5) * (sm - 1.0) + 0.5) / sm);
    vec3 lp = L - si * T;
    vec3 vp = V - so * T;
    float den = dot(lp, lp) * dot(vp, vp);
    float cphi = den > 1e-24 ? clamp(dot(lp, vp) * inversesqrt(den), -1.0, 1.0) : 0.0;
    float n = float(textureSize(hair_lut_n, 0).y);
    float x = ((cphi * 0.5 + 0.5) * (n - 1.0) + 0.5) / (2.0 * n);
    float y = (clamp(M.a, 0.0, 1.0) * (n - 1.0) + 0.5) / n;
    vec4 n0 = texture(hair_lut_n, vec2(x, y));
    vec3 n1 = texture(hair_lut_n, vec2(x + 0.5, y)).rgb;
    return max(m.specular * M.r * n0.a + M.g * n0.rgb + M.b * n1, vec3(0.0));
}

#endif
#endif
