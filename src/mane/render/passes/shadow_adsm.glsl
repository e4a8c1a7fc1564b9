// TressFX's approximated deep shadow map (AMD; Hunz 2016 §4): one depth map of the hair's first
// occluder d_s from light 0 (R32F, metres). Behind it the light is assumed to cross one fibre,
// then one more every u_adsm_spacing metres: n = 1 + max(0, d - d_s - bias) / spacing, and
// T = (1 - alpha)^n with 1 - alpha = exp(-u_adsm_tau). PCF on T.
#if SHADOWS == 3
uniform sampler2D u_adsm;
uniform float u_adsm_spacing;   // m between fibres along the light (adsm_spacing * strand width)
uniform float u_adsm_tau;       // optical depth of one fibre crossing: shadow_density * strand_opacity *
                                // its coverage of a texel (base.adsm_coverage)

// T at light depth z behind texel t's first occluder.
float adsm_texel(ivec2 t, float z) {
    float dz = z - texelFetch(u_adsm, t, 0).r - u_shadow_bias;
    float n = dz > 0.0 ? 1.0 + dz / u_adsm_spacing : 0.0;
    return exp(-u_adsm_tau * n);
}

float adsm_transmittance(vec3 P) {
    vec3 q = light_uvz(P);
    ivec2 size = textureSize(u_adsm, 0);
    float tr;
    PCF_BILINEAR(tr, q.xy * vec2(size) - 0.5, size, t, adsm_texel(t, q.z))
    return tr;
}
#endif
