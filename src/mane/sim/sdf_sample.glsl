// Trilinear sample of a MeshSDF's R32F 3D texture (texelFetch, so the same on every GPU).
// Node (i, j, k) sits at sdf_lo + (i, j, k) * sdf_h in the mesh's local frame; outside the
// box the value at the clamped point plus the distance to the box is returned.
uniform sampler3D sdf_texture;
uniform vec3 sdf_lo;
uniform float sdf_h;
uniform ivec3 sdf_res;

float sdf_value(vec3 x) {
    vec3 g = (x - sdf_lo) / sdf_h;
    vec3 hi = vec3(sdf_res - 1);
    vec3 gc = clamp(g, vec3(0.0), hi);
    ivec3 b = min(ivec3(floor(gc)), sdf_res - 2);
    vec3 f = gc - vec3(b);
    float v = 0.0;
    for (int c = 0; c < 8; ++c) {
        ivec3 o = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        vec3 w = mix(vec3(1.0) - f, f, vec3(o));
        v += w.x * w.y * w.z * texelFetch(sdf_texture, b + o, 0).r;
    }
    return v + length(g - gc) * sdf_h;
}
