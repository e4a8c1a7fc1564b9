// hair_multiple_scattering(T, V, L, m, transmittance): the light scattered more than once
// (through other fibres), added to hair_bsdf's single scattering by the renderer:
//     radiance = (hair_bsdf(..) * shadow + hair_multiple_scattering(.., transmittance)) * Li
// transmittance in [0, 1] is the fraction of light reaching the fragment through the hair
// in front of it (deep opacity map: exp(-opacity)); 1 at the lit surface. The renderer's
// shadow and transmittance may differ: with settings.ms_shadow_footprint > 0 the latter is the
// deep opacity map's over a wider texel box (hair_radiance.glsl, light0_visibility_ms).
//
// HAIR_MS_KARIS (Karis 2016, "Physically Based Hair Shading in Unreal", the UE4 code):
//   fake normal N = normalize(V - T (T.V)); kk = 1 - |T.L|; wrap = saturate((N.L + 1) / 4)
//   S_ms = sqrt(C) * (1/pi) * mix(wrap, kk, 0.33) * pow(C / luminance(C), 1 - transmittance)
//   ALU ~30.
// HAIR_MS_DUAL (Zinke, Yuksel, Weber and Keyser 2008, dual scattering, Algorithm 1 with the
//   deep opacity map's transmittance giving the number of hairs towards the light): global
//   forward scattering + local back-scattering from precomputed tables (dual_scattering.glsl,
//   dual_scattering.py; uniform sampler2D hair_dual_lut). ~14 texel fetches + ~150 ALU per light.
#ifndef MANE_HAIR_MULTIPLE_SCATTERING_GLSL
#define MANE_HAIR_MULTIPLE_SCATTERING_GLSL

vec3 hair_ms_karis(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance) {
    float tv = dot(T, V);
    vec3 N = safe_normalize(V - tv * T, vec3(0.0));
    float kk = 1.0 - abs(clamp(dot(T, L), -1.0, 1.0));
    float wrap = saturate((dot(N, L) + 1.0) * 0.25);
    float diffuse = INV_PI * mix(wrap, kk, 0.33);
    vec3 c = max(m.color, vec3(1e-4));
    vec3 tint = pow(c / max(luminance(c), 1e-4), vec3(1.0 - saturate(transmittance)));
    return sqrt(c) * diffuse * tint;
}

#include "dual_scattering.glsl"

// The fibre's albedo for light arriving alike from every direction (isotropic radiance L_in):
// L_out(V) = hair_isotropic_albedo(T, V, m) * L_in (the skin bounce's response, hair_radiance.glsl).
// HAIR_MS_DUAL: the dual-scattering tables' sum_p Abar_p = 2 pi sum_p N^G_p at the eye's
// |theta_o| (rows 5-7; for Chiang's fibre the full-circle average of its lobes, what the diffuse
// part of hair_ms_dual scatters: the same response to the same kind of light). Else the
// material's colour (Kajiya-Kay's diffuse, Karis's C).
vec3 hair_isotropic_albedo(vec3 T, vec3 V, HairMaterial m) {
#if HAIR_MULTIPLE_SCATTERING == HAIR_MS_DUAL
    float size = float(textureSize(hair_dual_lut, 0).x);
    float theta_o = hair_asin(dot(T, V));
    float xd = clamp(abs(theta_o) * (2.0 * INV_PI), 0.0, 1.0) * (size - 1.0);
    vec4 ng0 = hair_dual_fetch(xd, 5.0, size);
    return TWO_PI * (m.specular * ng0.a + ng0.rgb + hair_dual_fetch(xd, 6.0, size).rgb
                     + hair_dual_fetch(xd, 7.0, size).rgb);
#else
    return m.color;
#endif
}

vec3 hair_multiple_scattering(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance) {
#if HAIR_MULTIPLE_SCATTERING == HAIR_MS_KARIS
    return hair_ms_karis(T, V, L, m, transmittance);
#elif HAIR_MULTIPLE_SCATTERING == HAIR_MS_DUAL
    return hair_ms_dual(T, V, L, m, transmittance);
#else
    return vec3(0.0);
#endif
}

#endif
