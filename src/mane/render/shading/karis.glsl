// Karis 2016, "Physically Based Hair Shading in Unreal" (SIGGRAPH course notes; UE4 code):
//   M_p = g(beta_p; sin theta_i + sin theta_o - alpha_p)  (unit integral in sin theta_o)
//   alpha = 2 alpha_R (1, -1/2, -2) (Karis: -2s, s, 4s), beta = 2 r (1, 1/2, 2): the Gaussian
//   runs over sin theta_i + sin theta_o ~ 2 theta_h, so mane's theta_h width r = beta_R and
//   shift alpha_R enter doubled (without the 2 the lobes were half as wide and half as shifted
//   as Marschner's with the same settings)
//   N_R   = 1/4 cos(phi/2) F(sqrt(1/2 + 1/2 V.L))
//   N_TT  = (1 - F(cos theta_d sqrt(1 - h^2)))^2 C^(sqrt(1 - h^2 a^2) / (2 cos theta_d))
//           exp(-3.65 cos phi - 3.98),  a = 1/(1.19/cos theta_d + 0.36 cos theta_d),
//           h = cos(phi/2) (1 + a (0.6 - 0.8 cos phi))
//   N_TRT = (1 - f)^2 f C^(0.8 / cos theta_d) exp(17 cos phi - 16.78),
//           f = F(cos theta_d sqrt(1 - h^2)) with h = sqrt(3)/2  (its own lobe; not TT's)
//   F = Schlick with F0 = ((eta - 1)/(eta + 1))^2, C = color.
//   hair_bsdf = specular M_R N_R + M_TT N_TT + M_TRT N_TRT. Karis's M is normalised over
//   sin theta_o (d'Eon/pbrt convention: S already is f cos theta_i) so no cos theta_i and no
//   1/cos^2 theta_d appear.
// ALU: 2 atan (theta_d), 3 exp (M) + 2 exp (D), 2 pow (vec3), 4 sqrt, ~60 mul/add (~120).
#ifndef MANE_HAIR_KARIS_GLSL
#define MANE_HAIR_KARIS_GLSL

float hair_schlick(float f0, float x) {
    float t = 1.0 - clamp(x, 0.0, 1.0);
    float t2 = t * t;
    return f0 + (1.0 - f0) * t2 * t2 * t;
}

vec3 hair_karis(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    float si = clamp(dot(T, L), -1.0, 1.0);
    float so = clamp(dot(T, V), -1.0, 1.0);
    vec3 lp = L - si * T;
    vec3 vp = V - so * T;
    float den = dot(lp, lp) * dot(vp, vp);
    float cphi = den > 1e-24 ? clamp(dot(lp, vp) * inversesqrt(den), -1.0, 1.0) : 0.0;
    float ti = atan(si, max(length(lp), 1e-30));
    float to = atan(so, max(length(vp), 1e-30));
    float cos_d = max(cos(0.5 * (to - ti)), 1e-2);
    // cos(phi/2) = |l^ + v^| / 2: well conditioned at phi = pi, unlike sqrt(1/2 + cos(phi)/2)
    float chp = den > 1e-24
        ? min(0.5 * length(lp * inversesqrt(dot(lp, lp)) + vp * inversesqrt(dot(vp, vp))), 1.0)
        : 0.70710678118654752;
    float f0 = sqr((m.eta - 1.0) / (m.eta + 1.0));
    vec3 alpha = 2.0 * m.shift * vec3(1.0, -0.5, -2.0);
    vec3 beta = 2.0 * max(m.roughness, 1e-3) * vec3(1.0, 0.5, 2.0);
    vec3 x = (si + so - alpha) / beta;
    vec3 M = exp(-0.5 * x * x) * (0.39894228040143267794 / beta);
    vec3 C = max(m.color, vec3(1e-4));
    // R
    float nr = 0.25 * chp * hair_schlick(f0, sqrt(clamp(0.5 + 0.5 * dot(V, L), 0.0, 1.0)));
    // TT
    float a = 1.0 / (1.19 / cos_d + 0.36 * cos_d);
    float h = chp * (1.0 + a * (0.6 - 0.8 * cphi));
    float f = hair_schlick(f0, cos_d * sqrt(clamp(1.0 - h * h, 0.0, 1.0)));
    vec3 ntt = sqr(1.0 - f) * pow(C, vec3(0.5 * sqrt(max(0.0, 1.0 - sqr(h * a))) / cos_d))
               * exp(-3.65 * cphi - 3.98);
    // TRT
    float f2 = hair_schlick(f0, cos_d * 0.5);
    vec3 ntrt = sqr(1.0 - f2) * f2 * pow(C, vec3(0.8 / cos_d)) * exp(17.0 * cphi - 16.78);
    return max(vec3(m.specular * M.x * nr) + M.y * ntt + M.z * ntrt, vec3(0.0));
}

#endif
