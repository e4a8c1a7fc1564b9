// Kajiya-Kay 1989 (Hunz 2016 eqs. 26-31), with the projection factor on both terms, scaled to
// the energies of Chiang's fibre (kajiya_kay.py):
//
//   diffuse  = color / pi^2                             (directional albedo: color)
//   specular = specular * HAIR_KK_SPECULAR_NORM * cos(theta - theta')^p,
//              cos(theta - theta') = sin_tl sin_tv - (t.l)(t.v)
//   hair_bsdf = sin(t, l) * (diffuse + specular),  p = 1 / (2 roughness)^2 (clamped to [1, 4096])
//
// p makes the highlight as wide as Chiang's R lobe (standard deviation 2 beta_R in
// theta_i + theta_o), HAIR_KK_SPECULAR_NORM gives it the R lobe's albedo at specular 1.
// With sin(t, l) as the projection factor the underlying BRDF (diffuse + specular) is
// reciprocal (symmetric in V <-> L) and even in T -> -T.
// ALU: 2 dot, 2 sqrt, 1 pow, ~10 mul/add.  (~20 instructions)

#ifndef MANE_HAIR_KAJIYA_KAY_GLSL
#define MANE_HAIR_KAJIYA_KAY_GLSL

#ifndef HAIR_KK_SPECULAR_NORM
#if HAIR_MODEL == HAIR_MODEL_KAJIYA_KAY
#error "HAIR_KK_SPECULAR_NORM: ShadingSettings.defines() gives it"
#endif
#define HAIR_KK_SPECULAR_NORM 0.0   // another model is drawn
#endif

float hair_kk_exponent(float roughness) {
    return clamp(1.0 / max(4.0 * roughness * roughness, 1e-6), 1.0, 4096.0);
}

vec3 hair_kajiya_kay(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    float tl = clamp(dot(T, L), -1.0, 1.0);
    float tv = clamp(dot(T, V), -1.0, 1.0);
    float sl = sqrt(max(0.0, 1.0 - tl * tl));
    float sv = sqrt(max(0.0, 1.0 - tv * tv));
    float c = clamp(sl * sv - tl * tv, 0.0, 1.0);
    float spec = m.specular * HAIR_KK_SPECULAR_NORM * pow(c, hair_kk_exponent(m.roughness));
    return sl * (m.color * (INV_PI * INV_PI) + vec3(spec));
}

#endif
