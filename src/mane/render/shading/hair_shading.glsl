// mane/render/shading/hair_shading.glsl: per-fragment hair reflectance.
//
//     #include "shading/hair_shading.glsl"       (from src/mane/render/)
//     uniform HairMaterial u_material;            (the includer declares it; see
//                                                  ShadingSettings.material_uniforms())
//     vec3 f = hair_bsdf(T, V, L, m);              radiance_out = f * light_radiance
//     vec3 ms = hair_multiple_scattering(T, V, L, m, transmittance);
//
// T: unit tangent root -> tip; V: unit direction to the eye; L: unit direction to the light.
// hair_bsdf includes the cosine / projection factor (cos theta_i for the fibre models,
// sin(t, l) for Kajiya-Kay): for a light of radiance (or a directional light of irradiance
// normal to it) Li the reflected radiance is hair_bsdf * Li. Always finite and >= 0,
// also for T parallel to V or L.
//
// The model is chosen at compile time: #define HAIR_MODEL n (default MARSCHNER), see the
// HAIR_MODEL_* constants below (ShadingSettings.defines() writes it).
//
// Angles (Marschner 2003, Hunz 2016 sec. 3.1): sin theta_i = T.L, sin theta_o = T.V,
// theta_d = (theta_o - theta_i) / 2, theta_h = (theta_i + theta_o) / 2, phi = the angle
// between the projections of V and L on the normal plane, in [0, pi].
//
// Material conventions (all models):
//   color      linear RGB albedo (Kajiya-Kay/Sadeghi/Scheuermann diffuse and tint; Karis C)
//   specular   scale of the primary (R) highlight; 1 = physical for Marschner/Karis
//   sigma_a    absorption per unit fibre RADIUS (pbrt / Chiang 2016 convention), Marschner
//   roughness  longitudinal width beta_R in radians (Marschner: 5-10 deg = 0.087-0.175);
//              Karis: the width in sin-space; Kajiya-Kay/Scheuermann: exponent 1/roughness^2
//   shift      longitudinal shift alpha_R in radians (negative: -10..-5 deg)
//   eta        index of refraction (1.55)
//   glint      glint intensity (Marschner k_G multiplier, Sadeghi I_G, Scheuermann sparkle)
//   strand_rand per-strand random in [0, 1): Sadeghi glint angle, Scheuermann shift noise
//
// Lookup textures (HAIR_MODEL_MARSCHNER_LUT): uniform sampler2D hair_lut_m (RGBA16F over
// (theta_i, theta_o), evenly spaced in angle) and hair_lut_n (RGBA16F, 2 tiles side by side
// over (phi / pi, cos theta_d)); see luts.py / build_marschner_luts.
// HAIR_MODEL_CHIANG: uniform sampler2D hair_chiang_n (chiang.py / chiang.glsl).

#ifndef MANE_HAIR_SHADING_GLSL
#define MANE_HAIR_SHADING_GLSL

#include "common.glsl"

#define HAIR_MODEL_KAJIYA_KAY 0
#define HAIR_MODEL_MARSCHNER 1
#define HAIR_MODEL_MARSCHNER_LUT 2
#define HAIR_MODEL_SADEGHI 3
#define HAIR_MODEL_SCHEUERMANN 4
#define HAIR_MODEL_KARIS 5
#define HAIR_MODEL_CHIANG 6

#ifndef HAIR_MODEL
#define HAIR_MODEL HAIR_MODEL_MARSCHNER
#endif

// Multiple scattering: 0 none, 1 Karis 2016 approximation (default), 2 Zinke 2008 dual
// scattering (dual_scattering.glsl; needs the hair_dual_lut texture, ShadingSettings.bind()).
#define HAIR_MS_NONE 0
#define HAIR_MS_KARIS 1
#define HAIR_MS_DUAL 2
#ifndef HAIR_MULTIPLE_SCATTERING
#define HAIR_MULTIPLE_SCATTERING HAIR_MS_KARIS
#endif

struct HairMaterial {
    vec3 color;
    float specular;
    vec3 sigma_a;
    float roughness;
    float shift;
    float eta;
    float glint;
    float strand_rand;
};

#include "hair_common.glsl"

// The near field (ShadingSettings.near_field; Chiang's fibre only): the part of the fibre's
// width a pixel covers, h in [h0, h1] of -1 .. 1 along cross(T, V), from the pixel's offset h
// across it and the fibre's width in pixels (one pixel is 2 / width of h). hair_near_dh: that
// unclipped span (2 or more: the whole fibre, the far field); hair_near_h: the middle of
// [h0, h1]; hair_near_l0, _l1: (asin(h0, h1) + pi/2) / pi, where the table's layers lie, and
// hair_near_k = 2 / (h1 - h0) (once a pixel, not once a light). The drawing code sets them by
// hair_set_near before hair_bsdf (under #if HAIR_NEAR_FIELD: without it the hair programs are
// the far field's as they were); code that does not leaves the far field.
#ifndef HAIR_NEAR_FIELD
#define HAIR_NEAR_FIELD 0
#endif
float hair_near_h = 0.0;
float hair_near_dh = 2.0;
float hair_near_l0 = 0.0, hair_near_l1 = 1.0, hair_near_k = 1.0;
void hair_set_near(float h, float width_px) {
#if HAIR_NEAR_FIELD
    hair_near_dh = 2.0 / max(width_px, 1e-3);
    float h0 = clamp(h - 0.5 * hair_near_dh, -1.0, 1.0), h1 = clamp(h + 0.5 * hair_near_dh, -1.0, 1.0);
    hair_near_h = 0.5 * (h0 + h1);
    hair_near_l0 = hair_asin(h0) * INV_PI + 0.5;
    hair_near_l1 = hair_asin(h1) * INV_PI + 0.5;
    hair_near_k = 2.0 / max(h1 - h0, 1e-6);
#endif
}

// mane.gpu.glsl expands every #include (also inside #if), so each model file is included;
// unused functions cost nothing after compilation, and the LUT samplers are declared only
// for HAIR_MODEL_MARSCHNER_LUT (inside marschner_lut.glsl).
#if HAIR_MODEL < 0 || HAIR_MODEL > 6
#error "unknown HAIR_MODEL"
#endif
#include "kajiya_kay.glsl"
#include "marschner.glsl"
#include "marschner_lut.glsl"
#include "sadeghi.glsl"
#include "scheuermann.glsl"
#include "karis.glsl"
#include "chiang.glsl"
#include "multiple_scattering.glsl"

vec3 hair_bsdf(vec3 T, vec3 V, vec3 L, HairMaterial m) {
#if HAIR_MODEL == HAIR_MODEL_KAJIYA_KAY
    return hair_kajiya_kay(T, V, L, m);
#elif HAIR_MODEL == HAIR_MODEL_MARSCHNER
    return hair_marschner(T, V, L, m);
#elif HAIR_MODEL == HAIR_MODEL_MARSCHNER_LUT
    return hair_marschner_lut(T, V, L, m);
#elif HAIR_MODEL == HAIR_MODEL_SADEGHI
    return hair_sadeghi(T, V, L, m);
#elif HAIR_MODEL == HAIR_MODEL_SCHEUERMANN
    return hair_scheuermann(T, V, L, m);
#elif HAIR_MODEL == HAIR_MODEL_KARIS
    return hair_karis(T, V, L, m);
#else
    return hair_chiang(T, V, L, m);
#endif
}

#endif  // MANE_HAIR_SHADING_GLSL
