// Chiang et al. 2016 (pbrt-v4 HairBxDF / Mitsuba 3 `hair`), real-time form (chiang.py has the
// equations and the table layout; src/mane/twins/chiang.py is the NumPy twin):
//
//   hair_bsdf = sum_{p=0..3} M_p(theta_i, theta_o^p) Nbar_p(phi, |theta_o|)
//
// M_p: d'Eon's longitudinal lobe, analytic (v_0 = (2 roughness)^2, v_1 = v_0/4, v_2 = v_3 = 4 v_0;
// low-variance log form for v <= 0.1); the cuticle tilt alpha = m.shift rotates theta_o by
// -2 alpha (R), +alpha (TT), +4 alpha (TRT). Nbar_p: the azimuthal lobes times the attenuations,
// averaged over the fibre offset h, from the table hair_chiang_n (RGBA32F, 3 tiles of
// n_phi x n_theta over phi in [0, pi] and theta_o in [0, pi/2], bilinear at texel centres:
// tile 0 = (TT.rgb, R), 1 = (TRT.rgb, 0), 2 = (TRRT+.rgb, 0)); it bakes sigma_a, eta and beta_n.
// ALU: angles ~40 (1 atan for phi, 1 atan for theta_o), 4 M_p ~25 each (exp, log or a 10-term
// series), 3 bilinear fetches: ~150 ALU + 3 tex, under half the analytic Marschner.
#ifndef MANE_HAIR_CHIANG_GLSL
#define MANE_HAIR_CHIANG_GLSL
#if HAIR_MODEL == HAIR_MODEL_CHIANG

uniform sampler2D hair_chiang_n;

// I0 by its power series, 10 terms (pbrt); x <= 12 here.
float hair_chiang_i0(float x) {
    float x2 = x * x * 0.25;
    float term = 1.0, val = 1.0;
    for (int i = 1; i < 10; ++i) {
        term *= x2 / float(i * i);
        val += term;
    }
    return val;
}

// d'Eon et al. 2011 eq. 7 (pbrt Mp): unit integral of M cos(theta_i) over theta_i.
float hair_chiang_mp(float cos_i, float cos_o, float sin_i, float sin_o, float v) {
    float a = cos_i * cos_o / v;
    float b = sin_i * sin_o / v;
    if (v <= 0.1) {
        float log_i0 = a > 12.0 ? a + 0.5 * (-1.8378770664093453 - log(a) + 1.0 / (8.0 * a))
                                : log(hair_chiang_i0(a));
        return exp(log_i0 - b - 1.0 / v + 0.6931 + log(1.0 / (2.0 * v)));
    }
    // csch(1/v) / (2 v) = 1 / (v (e^(1/v) - e^(-1/v)))
    float e = exp(1.0 / v);
    return exp(-b) * hair_chiang_i0(a) / (v * (e - 1.0 / e));
}

vec3 hair_chiang(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    HairAngles an = hair_angles(T, V, L);
    float sin_i = an.sin_i, cos_i = an.cos_i;
    float sin_o = an.sin_o, cos_o = an.cos_o;
    float v0 = 4.0 * m.roughness * m.roughness;
    // tilt: theta_o + k alpha, k = (-2, 1, 4) for R, TT, TRT
    vec3 k = vec3(-2.0, 1.0, 4.0) * m.shift;
    vec3 sk = sin(k), ck = cos(k);
    vec3 sp = sin_o * ck + cos_o * sk;
    vec3 cp = abs(cos_o * ck - sin_o * sk);
    float m_r = hair_chiang_mp(cos_i, cp.x, sin_i, sp.x, v0);
    float m_tt = hair_chiang_mp(cos_i, cp.y, sin_i, sp.y, 0.25 * v0);
    float m_trt = hair_chiang_mp(cos_i, cp.z, sin_i, sp.z, 4.0 * v0);
    float m_3 = hair_chiang_mp(cos_i, cos_o, sin_i, sin_o, 4.0 * v0);
    vec2 size = vec2(textureSize(hair_chiang_n, 0));
    float n_phi = size.x / 3.0;
    float u = (clamp(an.phi * INV_PI, 0.0, 1.0) * (n_phi - 1.0) + 0.5) / size.x;
    float w = (clamp(abs(an.theta_o) * (2.0 * INV_PI), 0.0, 1.0) * (size.y - 1.0) + 0.5) / size.y;
    float tile = n_phi / size.x;
    vec4 n0 = texture(hair_chiang_n, vec2(u, w));
    vec3 n1 = texture(hair_chiang_n, vec2(u + tile, w)).rgb;
    vec3 n3 = texture(hair_chiang_n, vec2(u + 2.0 * tile, w)).rgb;
    vec3 f = vec3(m.specular * m_r * n0.a) + m_tt * n0.rgb + m_trt * n1 + m_3 * n3;
    return max(f, vec3(0.0));
}

#endif
#endif
