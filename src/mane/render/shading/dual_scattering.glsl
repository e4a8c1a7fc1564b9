// Placeholder until the Zinke 2008 global term lands: Karis's approximation.
#ifndef MANE_HAIR_DUAL_SCATTERING_GLSL
#define MANE_HAIR_DUAL_SCATTERING_GLSL
vec3 hair_ms_dual(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance) {
    return hair_ms_karis(T, V, L, m, transmittance);
}
#endif
