#version 430
// Evaluation harness: hair_bsdf and hair_multiple_scattering for N samples.
// samples[3i] = (T, strand_rand), samples[3i+1] = (V, transmittance), samples[3i+2] = (L, h)
// (u_near 1: Chiang's near field, the fibre's mean over h +- u_near_dh / 2, at h alone below
// HAIR_NEAR_MIN_DH; 0: the model as drawn far away)
// results[2i] = (hair_bsdf, 0), results[2i+1] = (hair_multiple_scattering, 0)
#include "hair_shading.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = B_HARNESS_SAMPLES) readonly buffer Samples { vec4 samples[]; };
layout(std430, binding = B_HARNESS_RESULTS) writeonly buffer Results { vec4 results[]; };
uniform HairMaterial u_material;
uniform uint u_count;
uniform int u_near;
uniform float u_near_dh;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec4 t = samples[3u * i], v = samples[3u * i + 1u], l = samples[3u * i + 2u];
    HairMaterial m = u_material;
    m.strand_rand = t.w;
    if (u_near != 0)   // a fibre 2 / u_near_dh pixels wide, the pixel at h
        hair_set_near(l.w, 2.0 / max(u_near_dh, 1e-6));
    results[2u * i] = vec4(hair_bsdf(t.xyz, v.xyz, l.xyz, m), 0.0);
    results[2u * i + 1u] = vec4(hair_multiple_scattering(t.xyz, v.xyz, l.xyz, m, v.w), 0.0);
}
