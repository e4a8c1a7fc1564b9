// Scheuermann 2004 (ATI, "Practical Real-Time Hair Rendering and Shading"): Kajiya-Kay with
// two highlights from shifted tangents.
//   N = normalize(V - T (T.V))      (the fibre normal facing the eye; no mesh normal here)
//   noise = (strand_rand - 0.5) * HAIR_SHIFT_NOISE
//   t1 = normalize(T + (shift + noise) N),  t2 = normalize(T + (-1.5 shift + noise) N)
//   spec(t, e) = smoothstep(-1, 0, t.H) * sin(t, H)^e,  H = normalize(L + V)
//   sparkle = 1 + glint (fract(61 strand_rand) - 0.5), clamped >= 0 (replaces the noise mask)
//   hair_bsdf = color/pi * mix(0.25, 1, saturate(N.L))
//             + k specular * spec(t1, 1/r^2) + k specular * color * sparkle * spec(t2, 1/(2r)^2)
// k = HAIR_SCHEUERMANN_NORM: the primary highlight has Chiang's R albedo at specular 1
// (scheuermann.py; unscaled, as published, hair was 24-35x the path tracer's brightness).
// ALU: 4 normalize, 2 pow, ~40 mul/add (~70).
#ifndef MANE_HAIR_SCHEUERMANN_GLSL
#define MANE_HAIR_SCHEUERMANN_GLSL

#ifndef HAIR_SCHEUERMANN_NORM
#if HAIR_MODEL == HAIR_MODEL_SCHEUERMANN
#error "HAIR_SCHEUERMANN_NORM: ShadingSettings.defines() gives it"
#endif
#define HAIR_SCHEUERMANN_NORM 0.0   // another model is drawn
#endif
#ifndef HAIR_SHIFT_NOISE
#define HAIR_SHIFT_NOISE 0.1
#endif

float hair_strand_specular(vec3 t, vec3 H, float e) {
    float th = clamp(dot(t, H), -1.0, 1.0);
    float s = sqrt(max(0.0, 1.0 - th * th));
    return smoothstep(-1.0, 0.0, th) * pow(s, e);
}

vec3 hair_scheuermann(vec3 T, vec3 V, vec3 L, HairMaterial m) {
    vec3 N = safe_normalize(V - dot(T, V) * T, vec3(0.0));
    float noise = (m.strand_rand - 0.5) * HAIR_SHIFT_NOISE;
    vec3 t1 = safe_normalize(T + (m.shift + noise) * N, T);
    vec3 t2 = safe_normalize(T + (-1.5 * m.shift + noise) * N, T);
    vec3 H = safe_normalize(L + V, T);
    float r = max(m.roughness, 1e-3);
    float e1 = min(1.0 / (r * r), 4096.0);
    float e2 = min(0.25 / (r * r), 4096.0);
    float sparkle = max(0.0, 1.0 + m.glint * (fract(61.0 * m.strand_rand) - 0.5));
    vec3 diffuse = m.color * INV_PI * mix(0.25, 1.0, saturate(dot(N, L)));
    float k = m.specular * HAIR_SCHEUERMANN_NORM;
    return diffuse + vec3(k * hair_strand_specular(t1, H, e1))
           + (k * sparkle * hair_strand_specular(t2, H, e2)) * m.color;
}

#endif
