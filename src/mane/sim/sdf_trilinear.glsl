// Trilinear sample of an SDF's R32F 3D texture of res nodes (texelFetch, so the same on every
// GPU). Node (i, j, k) sits at lo + (i, j, k) * h in the mesh's local frame; outside the box the
// value at the clamped point plus the distance to the box is returned. Used by sdf_sample.glsl
// (one SDF's uniforms) and contact.glsl (a texture of the array).
float sdf_trilinear(sampler3D tex, vec3 lo, float h, ivec3 res, vec3 x) {
    vec3 g = (x - lo) / h;
    vec3 gc = clamp(g, vec3(0.0), vec3(res - 1));
    ivec3 b = min(ivec3(floor(gc)), res - 2);
    vec3 f = gc - vec3(b);
    float v = 0.0;
    for (int c = 0; c < 8; ++c) {
        ivec3 o = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        vec3 w = mix(vec3(1.0) - f, f, vec3(o));
        v += w.x * w.y * w.z * texelFetch(tex, b + o, 0).r;
    }
    return v + length(g - gc) * h;
}
