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
// HAIR_NEAR_FIELD (ShadingSettings.near_field): where the drawing code says a pixel covers less
// than the whole fibre (hair_set_near), Nbar_p is the mean over that part of the width from the
// running integral's 3D table hair_chiang_c (chiang.near_table): 6 trilinear fetches and a signed
// azimuth a light instead of the 3 fetches (the pixel's part of the width, 2 asin, once a pixel);
// past HAIR_NEAR_MIN_DH, the fibre at the pixel's h.
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

#if HAIR_NEAR_FIELD
#ifndef HAIR_CHIANG_S
#define HAIR_CHIANG_S 0.3   // the azimuthal logistic's scale s (eq. 12; ShadingSettings.defines)
#endif
// the footprint (in h) under which the fibre is evaluated at its centre rather than averaged
// from the table (about one step of the table's gamma grid near h = 0)
#define HAIR_NEAR_MIN_DH 0.1

uniform sampler3D hair_chiang_c;   // chiang.near_table: 1/2 int_{-1}^{h} A_p N_p dh per tile

// The azimuth of L from V about -T, signed: its sine along -cross(T, V). A fibre met at
// h = sin(gamma_o) reflects R from phi = -2 gamma_o (pbrt's and Mitsuba's phi_i - phi_o with h
// along cross(T, V): tests/test_chiang.py, tests/test_reference.py).
float hair_chiang_signed_phi(HairAngles an, vec3 T, vec3 V, vec3 L) {
    vec3 vp = V - an.sin_o * T;
    vec3 lp = L - an.sin_i * T;
    return atan(-dot(lp, cross(T, V)), dot(lp, vp));   // |cross(T, V)| = |vp|: one scale on both
}

// The trimmed logistic of Chiang eq. 11 at x in [-pi, pi], scale s.
float hair_chiang_logistic(float x, float s) {
    float e = exp(-abs(x) / s);
    float norm = 1.0 / (1.0 + exp(-PI / s)) - 1.0 / (1.0 + exp(PI / s));
    return e / (s * (1.0 + e) * (1.0 + e) * norm);
}

// The fibre met at offset h (pbrt's and Mitsuba's evaluation at a ray's hit: twins/chiang.py
// fibre_near): A_p(h) N_p(phi - Phi(p, h)) with the lobes' M_p given (mp: R, TT, TRT, TRRT+).
vec3 hair_chiang_at(HairAngles an, float phi, HairMaterial m, vec4 mp, float h) {
    float cos_o = max(an.cos_o, 1e-4);
    float f = hair_fresnel(m.eta, m.eta, cos_o * sqrt(max(0.0, 1.0 - h * h)));
    float sin_t = an.sin_o / m.eta;
    float cos_t = sqrt(max(0.0, 1.0 - sin_t * sin_t));
    float etap = sqrt(max(0.0, m.eta * m.eta - an.sin_o * an.sin_o)) / cos_o;
    float sin_gt = h / etap;
    float cos_gt = sqrt(max(0.0, 1.0 - sin_gt * sin_gt));
    float gamma_o = hair_asin(h), gamma_t = hair_asin(sin_gt);
    vec3 tr = exp(-m.sigma_a * (2.0 * cos_gt / max(cos_t, 1e-4)));
    vec3 a1 = (1.0 - f) * (1.0 - f) * tr;
    vec3 a2 = a1 * tr * f;
    vec3 a3 = a2 * f * tr / max(vec3(1.0) - tr * f, vec3(1e-6));
    vec3 n;
    for (int p = 0; p < 3; ++p) {
        float x = phi - (2.0 * float(p) * gamma_t - 2.0 * gamma_o + float(p) * PI);
        x -= TWO_PI * floor((x + PI) / TWO_PI);   // to [-pi, pi)
        n[p] = hair_chiang_logistic(x, HAIR_CHIANG_S);
    }
    return vec3(m.specular * mp.x * f * n.x) + mp.y * n.y * a1 + mp.z * n.z * a2 + (mp.w * 0.5 * INV_PI) * a3;
}

// The table's tiles averaged over the pixel's part of the fibre (hair_set_near: h in [h0, h1] at
// the table's layer coordinates l0, l1): 2 (C(h1) - C(h0)) / (h1 - h0), C linear between the
// layers; a negative phi reads the mirrored part, N_p(-phi, h) = N_p(phi, -h) (l -> 1 - l).
// n0 = (TT.rgb, R), n1 = TRT, n3 = TRRT+, as the far field's table.
void hair_chiang_mean(float phi, float theta_o, out vec4 n0, out vec3 n1, out vec3 n3) {
    float l0 = hair_near_l0, l1 = hair_near_l1;
    if (phi < 0.0) {
        l0 = 1.0 - hair_near_l1;
        l1 = 1.0 - hair_near_l0;
        phi = -phi;
    }
    vec3 size = vec3(textureSize(hair_chiang_c, 0));
    float n_phi = size.x / 3.0;
    float u = (clamp(phi * INV_PI, 0.0, 1.0) * (n_phi - 1.0) + 0.5) / size.x;
    float w = (clamp(abs(theta_o) * (2.0 * INV_PI), 0.0, 1.0) * (size.y - 1.0) + 0.5) / size.y;
    float z0 = (l0 * (size.z - 1.0) + 0.5) / size.z;
    float z1 = (l1 * (size.z - 1.0) + 0.5) / size.z;
    float tile = n_phi / size.x;
    float k = hair_near_k;
    n0 = (texture(hair_chiang_c, vec3(u, w, z1)) - texture(hair_chiang_c, vec3(u, w, z0))) * k;
    n1 = (texture(hair_chiang_c, vec3(u + tile, w, z1)).rgb - texture(hair_chiang_c, vec3(u + tile, w, z0)).rgb) * k;
    n3 = (texture(hair_chiang_c, vec3(u + 2.0 * tile, w, z1)).rgb
          - texture(hair_chiang_c, vec3(u + 2.0 * tile, w, z0)).rgb) * k;
}
#endif

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
    vec4 n0;
    vec3 n1, n3;
#if HAIR_NEAR_FIELD
    // a pixel covers [h0, h1] of the fibre: its mean from the running integral's table, or
    // under HAIR_NEAR_MIN_DH the fibre at the pixel's h (2 or more: the whole fibre, below)
    if (hair_near_dh < 2.0) {
        float phi = hair_chiang_signed_phi(an, T, V, L);
        if (hair_near_dh < HAIR_NEAR_MIN_DH)   // (at the middle of the part on the fibre)
            return max(hair_chiang_at(an, phi, m, vec4(m_r, m_tt, m_trt, m_3), hair_near_h), vec3(0.0));
        hair_chiang_mean(phi, an.theta_o, n0, n1, n3);
    } else
#endif
    {
        vec2 size = vec2(textureSize(hair_chiang_n, 0));
        float n_phi = size.x / 3.0;
        float u = (clamp(an.phi * INV_PI, 0.0, 1.0) * (n_phi - 1.0) + 0.5) / size.x;
        float w = (clamp(abs(an.theta_o) * (2.0 * INV_PI), 0.0, 1.0) * (size.y - 1.0) + 0.5) / size.y;
        float tile = n_phi / size.x;
        n0 = texture(hair_chiang_n, vec2(u, w));
        n1 = texture(hair_chiang_n, vec2(u + tile, w)).rgb;
        n3 = texture(hair_chiang_n, vec2(u + 2.0 * tile, w)).rgb;
    }
    vec3 f = vec3(m.specular * m_r * n0.a) + m_tt * n0.rgb + m_trt * n1 + m_3 * n3;
    return max(f, vec3(0.0));
}

#endif
#endif
