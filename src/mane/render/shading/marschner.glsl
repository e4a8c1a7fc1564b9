// Marschner et al. 2003, analytic (Hunz 2016 sec. 3.3 and Algorithm 1). The equations,
// conventions and the two documented deviations (M normalised over theta_o, the energy
// clamp) are in luts.py's docstring; src/mane/twins/shading.py is the NumPy twin.
//
//   hair_bsdf = cos(theta_i) / cos^2(theta_d) * (specular M_R N_R + M_TT N_TT + M_TRT N_TRT)
//
// ALU (rough): angles ~40; M ~40 (3 exp, 6 cos for the clamp); per root: sin, cos, asin,
// 2 sqrt Fresnel, exp (~35); roots: R 1 (linear), TT 1 (Cardano: sqrt + pow), TRT 1-3
// (Cardano or trig: acos + 3 cos); caustic/glint ~40 with asin, sqrt, 2 exp.
// Total ~300-350 instructions, ~25 transcendentals: the most expensive model; use
// HAIR_MODEL_MARSCHNER_LUT (3 texture fetches, ~100 ALU) for full heads on slow GPUs.

#ifndef MANE_HAIR_MARSCHNER_GLSL
#define MANE_HAIR_MARSCHNER_GLSL

#ifndef HAIR_CAUSTIC_WIDTH
#define HAIR_CAUSTIC_WIDTH 0.2617993877991494
#endif
#ifndef HAIR_CAUSTIC_FADE
#define HAIR_CAUSTIC_FADE 0.3
#endif
#ifndef HAIR_CAUSTIC_LIMIT
#define HAIR_CAUSTIC_LIMIT 0.5
#endif
#ifndef HAIR_ENERGY_CLAMP
#define HAIR_ENERGY_CLAMP 1
#endif

const float HAIR_COS_D_FLOOR = 1e-2;
const float HAIR_DPHI_FLOOR = 1e-3;
const float HAIR_INV_PI3 = 0.03225153443319948918;   // 1 / pi^3

// Unpolarised Fresnel at incidence gamma (cos_g): perpendicular with eta', parallel with eta''.
float hair_fresnel(float eta1, float eta2, float cos_g) {
    float sin2 = max(0.0, 1.0 - cos_g * cos_g);
    float ct1 = sqrt(max(0.0, 1.0 - sin2 / (eta1 * eta1)));
    float rs = (cos_g - eta1 * ct1) / max(cos_g + eta1 * ct1, 1e-30);
    float ct2 = sqrt(max(0.0, 1.0 - sin2 / (eta2 * eta2)));
    float rp = (eta2 * cos_g - ct2) / max(eta2 * cos_g + ct2, 1e-30);
    return 0.5 * (rs * rs + rp * rp);
}

// A(p, h) for p = 1, 2 (colour); p = 0 is the Fresnel alone.
vec3 hair_attenuation(int p, float h, float eta1, float eta2, float cos_t, vec3 sigma_a) {
    float f = hair_fresnel(eta1, eta2, sqrt(max(0.0, 1.0 - h * h)));
    float sin_gt = h / eta1;
    float cos_gt = sqrt(max(0.0, 1.0 - sin_gt * sin_gt));
    vec3 t = exp(-sigma_a * (2.0 * cos_gt / cos_t));
    float omf = 1.0 - f;
    return p == 1 ? (omf * omf) * t : (omf * omf * f) * t * t;
}

float hair_phi_hat(float p, float c, float g) {
    return -8.0 * p * c * HAIR_INV_PI3 * g * g * g + (6.0 * p * c * INV_PI - 2.0) * g + p * PI;
}

// Roots gamma of phi^(p, gamma) = phi (mod 2 pi), p = 1 or 2, phi in [0, pi]; returns the count
// of roots in [-pi/2, pi/2] (invalid ones are set to 0 with weight skipped by the caller).
int hair_roots(float p, float c, float phi, out vec3 roots, out bvec3 valid) {
    float a = -8.0 * p * c * HAIR_INV_PI3;
    float b = 6.0 * p * c * INV_PI - 2.0;
    float d = p * PI - phi - (p > 1.5 ? TWO_PI : 0.0);
    float P = b / a, Q = d / a;
    float disc = 0.25 * Q * Q + P * P * P / 27.0;
    if (disc > 0.0) {
        float s = sqrt(disc);
        float w = -0.5 * Q - (Q >= 0.0 ? s : -s);
        float u = sign(w) * pow(abs(w), 1.0 / 3.0);
        roots = vec3(u - P / (3.0 * (u == 0.0 ? 1.0 : u)), 0.0, 0.0);
        valid = bvec3(abs(roots.x) <= HALF_PI, false, false);
    } else {
        float r = sqrt(max(-P / 3.0, 0.0));
        float th = hair_acos(-Q / (2.0 * max(r * r * r, 1e-30))) / 3.0;
        roots = 2.0 * r * cos(vec3(th, th - TWO_PI / 3.0, th - 2.0 * TWO_PI / 3.0));
        valid = lessThanEqual(abs(roots), vec3(HALF_PI));
    }
    return int(valid.x) + int(valid.y) + int(valid.z);
}

// N_TT (p = 1) or N_TRT before the caustic treatment (p = 2).
vec3 hair_n_p(float p, float c, float phi, float eta1, float eta2, float cos_t, vec3 sigma_a) {
    vec3 roots;
    bvec3 valid;
    hair_roots(p, c, phi, roots, valid);
    vec3 sum = vec3(0.0);
    for (int k = 0; k < 3; ++k) {
        if (!valid[k]) continue;
        float g = roots[k];
        // one Newton step: float32 Cardano/trig roots lose ~sqrt(eps) near the caustic fold
        float d1 = -24.0 * p * c * HAIR_INV_PI3 * g * g + 6.0 * p * c * INV_PI - 2.0;
        float res = hair_phi_hat(p, c, g) - phi - (p > 1.5 ? TWO_PI : 0.0);
        if (abs(d1) > 1e-2) g = clamp(g - res / d1, -HALF_PI, HALF_PI);
        float dphi = abs(-24.0 * p * c * HAIR_INV_PI3 * g * g + 6.0 * p * c * INV_PI - 2.0);
        float w = cos(g) / (2.0 * max(dphi, HAIR_DPHI_FLOOR));
        sum += w * hair_attenuation(int(p), sin(g), eta1, eta2, cos_t, sigma_a);
    }
    return sum;
}

// The azimuthal terms at (cos theta_d, phi): N_R in .w of n0, N_TT in n0.rgb, N_TRT in n1.
void hair_marschner_n(float cos_d, float phi, HairMaterial m, out vec4 n0, out vec3 n1) {
    float eta = m.eta;
    cos_d = max(cos_d, HAIR_COS_D_FLOOR);
    float sin2 = max(0.0, 1.0 - cos_d * cos_d);
    float root = sqrt(eta * eta - sin2);
    float eta1 = root / cos_d;
    float eta2 = eta * eta / eta1;
    float cos_t = root / eta;
    float c = hair_asin(1.0 / eta1);
    // R: phi = -2 gamma, one root; N_R = F cos(phi / 2) / 4
    float g0 = -0.5 * phi;
    float n_r = hair_fresnel(eta1, eta2, cos(g0)) * cos(g0) * 0.25;
    vec3 n_tt = hair_n_p(1.0, c, phi, eta1, eta2, cos_t, m.sigma_a);
    vec3 n_trt = hair_n_p(2.0, c, phi, eta1, eta2, cos_t, m.sigma_a);
    // caustics and glints (Hunz Algorithm 1)
    float wc = HAIR_CAUSTIC_WIDTH;
    bool below = eta1 < 2.0;
    float gc = below ? sqrt(max(12.0 * c * INV_PI - 2.0, 0.0) / (48.0 * c * HAIR_INV_PI3)) : 0.0;
    float hc = sin(gc);
    float cgc = cos(gc);
    float d2 = abs(96.0 * c * HAIR_INV_PI3 * gc) / max(cgc * cgc, 1e-30);
    float dh = below ? min(HAIR_CAUSTIC_LIMIT, 2.0 * sqrt(2.0 * wc / max(d2, 1e-30))) : HAIR_CAUSTIC_LIMIT;
    float t = below ? 1.0 : 1.0 - smoothstep(2.0, 2.0 + HAIR_CAUSTIC_FADE, eta1);
    float phic = below ? abs(hair_phi_hat(2.0, c, gc) - TWO_PI) : 0.0;
    float x1 = (phi - phic) / wc, x2 = (phi + phic) / wc;
    float e1 = exp(-0.5 * x1 * x1), e2 = exp(-0.5 * x2 * x2);
    n_trt *= (1.0 - t * e1) * (1.0 - t * e2);
    n_trt += (t * m.glint * dh * (e1 + e2) * (0.39894228040143267794 / wc))
             * hair_attenuation(2, hc, eta1, eta2, cos_t, m.sigma_a);
    n0 = vec4(n_tt, n_r);
    n1 = n_trt;
}

// M_R, M_TT, M_TRT (with the energy clamp when enabled).
vec3 hair_marschner_m(float theta_i, float theta_o, HairMaterial m) {
    vec3 alpha = m.shift * vec3(1.0, -0.5, -1.5);
    vec3 beta = m.roughness * vec3(1.0, 0.5, 2.0);
    vec3 x = (0.5 * (theta_i + theta_o) - alpha) / beta;
    vec3 M = 0.5 * exp(-0.5 * x * x) * (0.39894228040143267794 / beta);
#if HAIR_ENERGY_CLAMP
    vec3 cn = cos(alpha - theta_i);
    vec3 cd = cos(2.0 * alpha - theta_i);
    M *= min(vec3(1.0), (cn * cn) / max(cd * cd, vec3(1e-12)));
#endif
    return M;
}

vec3 hair_marschner(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    HairAngles a = hair_angles(T, V, L);
    float cos_d = max(cos(0.5 * (a.theta_o - a.theta_i)), HAIR_COS_D_FLOOR);
    vec3 M = hair_marschner_m(a.theta_i, a.theta_o, m);
    vec4 n0;
    vec3 n1;
    hair_marschner_n(cos_d, a.phi, m, n0, n1);
    vec3 s = m.specular * M.x * n0.w + M.y * n0.rgb + M.z * n1;
    return max(s * (a.cos_i / (cos_d * cos_d)), vec3(0.0));
}

#endif
