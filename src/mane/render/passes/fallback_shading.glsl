// A stand-in for mane/render/shading/hair_shading.glsl with its interface (Kajiya-Kay), used
// only when that module is missing. The real models live in mane.render.shading.
struct HairMaterial {
    vec3 color; float specular; vec3 sigma_a; float roughness;
    float shift; float eta; float glint; float strand_rand;
};
vec3 hair_bsdf(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    float tl = dot(T, L), tv = dot(T, V);
    float sin_tl = sqrt(max(0.0, 1.0 - tl * tl)), sin_tv = sqrt(max(0.0, 1.0 - tv * tv));
    vec3 diffuse = m.color * sin_tl * 0.3183;
    float spec = max(0.0, tl * tv + sin_tl * sin_tv);
    float e = 2.0 / max(m.roughness * m.roughness, 1e-3);
    return diffuse + vec3(m.specular * pow(spec, e) * sin_tl * 0.3);
}
vec3 hair_multiple_scattering(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance) {
    return vec3(0.0);
}
