// Sadeghi et al. 2010 artist-friendly pseudo scattering function (Hunz eqs. 60-64):
//   f' = 1/cos^2(theta_d) sum_p C_p I_p M'_p N'_p,  M'_p = exp(-(theta_h - alpha_p)^2 / (2 beta_p^2))
//   (unit height), N'_R = cos(phi/2), N'_TT = g'(gamma_TT, pi - phi),
//   N'_TRT = cos(phi/2) + I_G g'(gamma_G, G_angle - phi), G_angle = 30..45 deg from strand_rand.
// C_R = 1 (white), C_TT = C_TRT = color; I_R = 0.45 specular, I_TT = 1, I_TRT = 0.3 (Hunz
// Fig. 32's hand match to Marschner); I_G = glint; alpha/beta tied as Marschner's.
// gamma_TT = HAIR_TT_WIDTH, gamma_G = HAIR_GLINT_WIDTH (radians). hair_bsdf = f' cos(theta_i).
// Not energy conserving (no Fresnel), as in the paper; mane scales the whole function by
// HAIR_SADEGHI_NORM so that its R lobe has Chiang's R albedo at specular 1 (sadeghi.py).
// ALU: angles ~40, 5 exp, 2 cos, ~30 mul/add (~90).
#ifndef MANE_HAIR_SADEGHI_GLSL
#define MANE_HAIR_SADEGHI_GLSL

#ifndef HAIR_TT_WIDTH
#define HAIR_TT_WIDTH 0.4363323129985824
#endif
#ifndef HAIR_SADEGHI_NORM
#if HAIR_MODEL == HAIR_MODEL_SADEGHI
#error "HAIR_SADEGHI_NORM: ShadingSettings.defines() gives it"
#endif
#define HAIR_SADEGHI_NORM 0.0   // another model is drawn
#endif
#ifndef HAIR_GLINT_WIDTH
#define HAIR_GLINT_WIDTH 0.08726646259971647
#endif

const vec3 HAIR_SADEGHI_I = vec3(0.45, 1.0, 0.3);

vec3 hair_sadeghi(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    HairAngles a = hair_angles(T, V, L);
    float th = 0.5 * (a.theta_i + a.theta_o);
    float cos_d = max(cos(0.5 * (a.theta_o - a.theta_i)), 1e-2);
    vec3 alpha = m.shift * vec3(1.0, -0.5, -1.5);
    vec3 beta = m.roughness * vec3(1.0, 0.5, 2.0);
    vec3 x = (th - alpha) / beta;
    vec3 M = HAIR_SADEGHI_I * exp(-0.5 * x * x);
    float nr = cos(0.5 * a.phi);
    float xt = (PI - a.phi) / HAIR_TT_WIDTH;
    float ntt = exp(-0.5 * xt * xt);
    float g_angle = radians(30.0 + 15.0 * m.strand_rand);
    float xg = (g_angle - a.phi) / HAIR_GLINT_WIDTH;
    float ntrt = nr + m.glint * exp(-0.5 * xg * xg);
    vec3 f = vec3(m.specular * M.x * nr) + m.color * (M.y * ntt + M.z * ntrt);
    return max(f * (HAIR_SADEGHI_NORM * a.cos_i / (cos_d * cos_d)), vec3(0.0));
}

#endif
