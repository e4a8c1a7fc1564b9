// Zinke, Yuksel, Weber and Keyser 2008, "Dual Scattering Approximation for Fast Multiple
// Scattering in Hair", real-time (deep opacity map) variant, Algorithm 1:
//
//     hair_ms_dual(T, V, L, m, transmittance)  (HAIR_MULTIPLE_SCATTERING == HAIR_MS_DUAL)
//
// The renderer adds hair_bsdf(..) * transmittance itself (the paper's directFraction *
// f_direct_s), so this returns the rest of Algorithm 1's (F_direct + F_scatter) cos theta_i:
//
//   t  = directFraction = transmittance (deep opacity map, 1 at the lit surface; with
//        settings.ms_shadow_footprint > 0 the map's mean over that texel box, while the direct
//        light hair_bsdf(..) * vis uses the pcf box: lighting.glsl, light0_visibility_ms)
//   n  = -log(t), at most HAIR_DUAL_MAX_HAIRS: the mean number of fibres a ray towards the
//        light meets. Fibres lie at random, so the count k is Poisson with mean n and the
//        light that meets none is exp(-n) = t, which is what the deep opacity map measures.
//   T_f      = sum_k P(k) a_f^k = exp(-n (1 - a_f(theta_i)))   Eq. 7 (Zinke's product of a_f over
//              the hairs in front) averaged over the Poisson count; it includes the direct t.
//              (It replaces a_f^n with n = log t / log(1 - opacity), which counted every fibre
//              as met: brown fibres, a_f < 1 - opacity, then lost the global term altogether.)
//   sigma_f2 = n beta_f^2(theta_i)                   Eq. 9
//   f_direct_back  = A_b G(theta_h - Delta_b, sigma_b^2)            / (4 pi cos^2 theta_d)  Eq. 15
//   f_scatter_back = A_b G(theta_h - Delta_b, sigma_b^2 + sigma_f2) / (4 pi cos^2 theta_d)
//   M^G_p    = 1/2 G(theta_h - alpha_p, beta_p^2 + sigma_f2)        (Algorithm 1)
//   f_scatter_s = (specular M^G_R N^G_R + M^G_TT N^G_TT + M^G_TRT N^G_TRT) / cos^2 theta_d
//   result = cos theta_i [ t d_b f_direct_back
//                          + max(T_f - t, 0) d_f (f_scatter_s + d_b f_scatter_back) ]
// Chiang's fibre: only TT keeps the beam's direction (I_f^TT, row 8, per channel), so the
// directional part is max(T_dir - t, 0), T_dir = exp(-n (1 - I_f^TT)), and the rest of T_f is
// diffuse: + d_f (T_f - T_dir) T_f albedo(theta_o) / 4 pi (isotropic at the same fluence, the
// extra T_f for its doubled path; albedo = 2 pi sum_p N^G_p), docs/quality.md item (6).
//
// G(x, v) = exp(-x^2 / 2v) / sqrt(2 pi v) (unit integral over theta_h). Normalisation follows
// hair_bsdf (luts.py), not the paper's BCSDF: 1/2 G is unit-integral over theta_o and the
// back-scattering lobe is azimuthally uniform (1 / 2 pi), so f_back's directional albedo is
// ~A_b; the paper's 2/pi (f_back) and pi (F_scatter's back term) prefactors belong to its
// normalisation and are not used. T_f is the paper's product without d_f (Algorithm 1
// applies d_f to (T_f - directFraction)); n = 0 (t = 1) leaves only the local
// back-scattering of the direct light. theta_i, theta_o: inclinations of L and V; theta_h,
// theta_d: their half sum / half difference (Marschner), so the tables are read at the
// light's inclination theta_i and N^G at |theta_d|.
//
// Chiang's fibre (HAIR_MODEL_CHIANG): four lobes (TRRT+ in row 7, alpha 0, width 2 roughness),
// lobe shifts (1, -1/2, -2) alpha, and N^G read at the eye's |theta_o| (its table's variable;
// the full-circle average of Nbar_p, 2 pi N^G_p = Abar_p: energy-conserving, dual_scattering.py);
// cos theta_i / cos^2 theta_d is Chiang's M_p normalisation near the specular cone too.
//
// Tables (dual_scattering.py, ShadingSettings.dual_lut()): uniform sampler2D hair_dual_lut,
// RGBA32F, 9 rows x size (64) texels, linear in x (interpolated in the shader from two
// texelFetch, hair_dual_fetch), read at row centres:
//   over theta_i in [-pi/2, pi/2]: 0 A_b, 1 Delta_b, 2 sigma_b^2, 3 a_f, 4 beta_f^2,
//                                  8 I_f^TT (Chiang) (rgb)
//   over |theta_d| in [0, pi/2]:  5 N^G_TT (rgb) + N^G_R (a), 6 N^G_TRT (rgb), 7 N^G_TRRT+ (rgb)
//   (Chiang: rows 5-7 over |theta_o|)
// Defines (ShadingSettings.defines()): HAIR_DUAL_DF d_f, HAIR_DUAL_DB d_b, HAIR_DUAL_MAX_HAIRS.
//
// Cost per light: hair_angles (~40 ALU, 3 atan) + 3 lookups (2 texelFetch + mix each) and ~25
// ALU (1 exp, 1 rsqrt per channel) when t = 1; in the shadow +4 lookups, 1 log, pow, 4 vec3
// Gaussians (~60 ALU, 12 exp): about 14 texel fetches + ~150 ALU, under half the analytic
// Marschner's cost.
#ifndef MANE_HAIR_DUAL_SCATTERING_GLSL
#define MANE_HAIR_DUAL_SCATTERING_GLSL

#ifndef HAIR_DUAL_DF
#define HAIR_DUAL_DF 1.0
#endif
#ifndef HAIR_DUAL_DB
#define HAIR_DUAL_DB 0.7
#endif
#ifndef HAIR_DUAL_MAX_HAIRS
#define HAIR_DUAL_MAX_HAIRS 64.0
#endif

#if HAIR_MULTIPLE_SCATTERING == HAIR_MS_DUAL

uniform sampler2D hair_dual_lut;

// Row `row` at texel coordinate x in [0, size - 1] (grid point j at x = j), linear in x.
// Two texelFetch and a float32 mix rather than the sampler's linear filter: GPUs interpolate
// with low-precision weights (NVIDIA: 8 fractional bits, an error of up to 1/512 of the step
// between neighbouring texels, ~2e-3 relative on these tables), while the NumPy twin
// (np.interp) interpolates exactly. Same texel-centre convention as textureLod at
// ((x + 0.5) / size, (row + 0.5) / 8) with clamp-to-edge, and the result no longer depends
// on the sampler's filter or the GPU's filtering precision.
vec4 hair_dual_fetch(float x, float row, float size) {
    float xc = clamp(x, 0.0, size - 1.0);
    float i0 = min(floor(xc), max(size - 2.0, 0.0));
    int r = int(row);
    vec4 t0 = texelFetch(hair_dual_lut, ivec2(int(i0), r), 0);
    vec4 t1 = texelFetch(hair_dual_lut, ivec2(int(min(i0 + 1.0, size - 1.0)), r), 0);
    return mix(t0, t1, xc - i0);
}

// G(x, v) per channel, v the variance.
vec3 hair_dual_gauss(vec3 v, vec3 x) {
    v = max(v, vec3(1e-8));
    return exp(-0.5 * x * x / v) * inversesqrt(TWO_PI * v);
}

vec3 hair_ms_dual(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance) {
    HairAngles a = hair_angles(T, V, L);
    float theta_h = 0.5 * (a.theta_i + a.theta_o);
    float theta_d = 0.5 * (a.theta_o - a.theta_i);
    float cos_d = max(cos(theta_d), HAIR_COS_D_FLOOR);
    float inv_cd2 = 1.0 / (cos_d * cos_d);
    float size = float(textureSize(hair_dual_lut, 0).x);
    float xi = clamp((a.theta_i + HALF_PI) * INV_PI, 0.0, 1.0) * (size - 1.0);
    vec3 A_b = hair_dual_fetch(xi, 0.0, size).rgb;
    vec3 delta_b = hair_dual_fetch(xi, 1.0, size).rgb;
    vec3 sigma_b2 = hair_dual_fetch(xi, 2.0, size).rgb;
    float back_norm = 0.25 * INV_PI * inv_cd2;
    float t = clamp(transmittance, 0.0, 1.0);
    // local back-scattering of the light that arrives unscattered
    vec3 f = (t * HAIR_DUAL_DB * back_norm) * A_b * hair_dual_gauss(sigma_b2, vec3(theta_h) - delta_b);
    vec3 f_diffuse = vec3(0.0);
    if (t < 1.0) {
        float n = min(-log(max(t, 1e-30)), HAIR_DUAL_MAX_HAIRS);
        vec3 a_f = clamp(hair_dual_fetch(xi, 3.0, size).rgb, 0.0, 1.0);
        vec3 sigma_f2 = n * hair_dual_fetch(xi, 4.0, size).rgb;
        vec3 T_f = exp(-n * (1.0 - a_f));
#if HAIR_MODEL == HAIR_MODEL_CHIANG
        // the light that kept the beam's direction (TT at every fibre met: row 8) and the
        // diffuse rest, which crosses the fibres at random angles (twice the path: * T_f)
        vec3 T_dir = exp(-n * (1.0 - hair_dual_fetch(xi, 8.0, size).rgb));
        vec3 scattered = max(T_dir - vec3(t), vec3(0.0));
        vec3 diffuse = max(T_f - T_dir, vec3(0.0)) * T_f;
#else
        vec3 scattered = max(T_f - vec3(t), vec3(0.0));
#endif
#if HAIR_MODEL == HAIR_MODEL_CHIANG
        float xd = clamp(abs(a.theta_o) * (2.0 * INV_PI), 0.0, 1.0) * (size - 1.0);
        vec3 alpha = m.shift * vec3(1.0, -0.5, -2.0);
#else
        float xd = clamp(abs(theta_d) * (2.0 * INV_PI), 0.0, 1.0) * (size - 1.0);
        vec3 alpha = m.shift * vec3(1.0, -0.5, -1.5);
#endif
        vec4 ng0 = hair_dual_fetch(xd, 5.0, size);
        vec3 ng_trt = hair_dual_fetch(xd, 6.0, size).rgb;
        vec3 ng_trrt = hair_dual_fetch(xd, 7.0, size).rgb;
        vec3 beta = m.roughness * vec3(1.0, 0.5, 2.0);
        beta *= beta;
        vec3 mg_r = 0.5 * hair_dual_gauss(beta.x + sigma_f2, vec3(theta_h - alpha.x));
        vec3 mg_tt = 0.5 * hair_dual_gauss(beta.y + sigma_f2, vec3(theta_h - alpha.y));
        vec3 mg_trt = 0.5 * hair_dual_gauss(beta.z + sigma_f2, vec3(theta_h - alpha.z));
        vec3 mg_trrt = 0.5 * hair_dual_gauss(beta.z + sigma_f2, vec3(theta_h));
        vec3 f_scatter_s = (m.specular * ng0.a * mg_r + mg_tt * ng0.rgb + mg_trt * ng_trt + mg_trrt * ng_trrt)
                           * inv_cd2;
        vec3 f_scatter_back = back_norm * A_b * hair_dual_gauss(sigma_b2 + sigma_f2, vec3(theta_h) - delta_b);
        f += scattered * HAIR_DUAL_DF * (f_scatter_s + HAIR_DUAL_DB * f_scatter_back);
#if HAIR_MODEL == HAIR_MODEL_CHIANG
        // isotropic radiance diffuse / 4 pi (fluence kept) times the fibre's albedo at theta_o,
        // sum_p Abar_p = 2 pi sum_p N^G_p (rows 5-7, already fetched): diffuse sum N^G / 2
        f_diffuse = (0.5 * HAIR_DUAL_DF) * diffuse * (m.specular * ng0.a + ng0.rgb + ng_trt + ng_trrt);
#endif
    }
    return max(f * a.cos_i + f_diffuse, vec3(0.0));
}

#else

vec3 hair_ms_dual(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance) {
    return vec3(0.0);
}

#endif
#endif
