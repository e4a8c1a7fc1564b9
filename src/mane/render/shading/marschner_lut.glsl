// Marschner 2003 from lookup textures (Nguyen and Donnelly 2005 layout, Hunz Algorithm 2):
// the tables are built in NumPy by luts.build_marschner_luts (layout, resolution and format
// in luts.py: M RGBA16F size^2 over (theta_i, theta_o), uniform in angle, RGB = M_R, M_TT,
// M_TRT without the energy clamp; N RGBA16F (2 size) x size over (phi, cos theta_d), left
// tile N_TT (+ N_R, unused), right tile N_TRT). Computed here, not baked (not bilinear-friendly
// near grazing): cos theta_i / cos^2 theta_d, the energy clamp and N_R. The tables bake
// sigma_a, eta, roughness, shift, glint and the caustic constants: u_material contributes
// `specular`, and `eta` and `shift` for the analytic parts, (ShadingSettings.bind() rebuilds and caches the tables per
// material).
// ALU: 3 dot, 2 length, 1 cross, 3 atan, 2 cos (+6 with HAIR_ENERGY_CLAMP), 3 sqrt, ~60
// mul/add/div, 3 bilinear fetches (~100 + 3 tex; the analytic model is ~300-350 with ~25 transcendentals).
#ifndef MANE_HAIR_MARSCHNER_LUT_GLSL
#define MANE_HAIR_MARSCHNER_LUT_GLSL
#if HAIR_MODEL == HAIR_MODEL_MARSCHNER_LUT

uniform sampler2D hair_lut_m;
uniform sampler2D hair_lut_n;

vec3 hair_marschner_lut(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    float si = clamp(dot(T, L), -1.0, 1.0);
    float so = clamp(dot(T, V), -1.0, 1.0);
    vec3 lp = L - si * T;
    vec3 vp = V - so * T;
    float ci = min(length(lp), 1.0);
    float co = min(length(vp), 1.0);
    // Angles exactly as hair_angles (hair_common.glsl), so the grazing ends match the analytic model.
    float ti = atan(si, max(ci, 1e-30));
    float to = atan(so, max(co, 1e-30));
    float x = dot(vp, lp);
    float y = length(cross(vp, lp));
    float phi = (abs(x) + y > 1e-12) ? atan(y, x) : HALF_PI;
    vec2 sm = vec2(textureSize(hair_lut_m, 0));
    vec3 M = texture(hair_lut_m, ((vec2(ti, to) * INV_PI + 0.5) * (sm - 1.0) + 0.5) / sm).rgb;
#if HAIR_ENERGY_CLAMP
    // The energy clamp (hair_marschner_m) analytically: it depends on theta_i only but falls
    // from 1 to 0 within 5 deg of grazing (pole of its ratio at theta_i = 90 + 2 alpha_p, zero
    // at 90 + alpha_p), which bilinear filtering over 0.7 deg texels misses by up to 9 % of
    // the peak. 6 cos, 3 div.
    vec3 alpha = m.shift * vec3(1.0, -0.5, -1.5);
    vec3 cn = cos(alpha - ti);
    vec3 cc = cos(2.0 * alpha - ti);
    M *= min(vec3(1.0), (cn * cn) / max(cc * cc, vec3(1e-12)));
#endif
    float cos_d = max(cos(0.5 * (to - ti)), HAIR_COS_D_FLOOR);
    float n = float(textureSize(hair_lut_n, 0).y);
    float u = (clamp(phi * INV_PI, 0.0, 1.0) * (n - 1.0) + 0.5) / (2.0 * n);
    float v = (cos_d * (n - 1.0) + 0.5) / n;
    vec4 n0 = texture(hair_lut_n, vec2(u, v));
    vec3 n1 = texture(hair_lut_n, vec2(u + 0.5, v)).rgb;
    // N_R analytically (as hair_marschner_n): its Fresnel has a square-root kink at total internal
    // reflection of the parallel component (eta'' < 1, i.e. theta_d beyond ~55 deg) that a bilinear
    // table smears over a texel (up to 20 % of the peak at 256^2); it costs ~25 ALU, 3 sqrt, 1 cos.
    float eta = m.eta;
    float root = sqrt(eta * eta - (1.0 - cos_d * cos_d));
    float eta1 = root / cos_d;
    float cg = cos(0.5 * phi);
    float n_r = hair_fresnel(eta1, eta * eta / eta1, cg) * cg * 0.25;
    vec3 s = m.specular * M.r * n_r + M.g * n0.rgb + M.b * n1;
    return max(s * (ci / (cos_d * cos_d)), vec3(0.0));
}

#endif
#endif
