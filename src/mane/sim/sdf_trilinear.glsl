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

// The central difference v(x + e a) - v(x - e a) of the trilinear field along each axis a, e = h / 2
// (not divided by 2e: callers normalise it), from 20 texels. Both points of a difference along x
// lie in neighbouring cells with the same fraction u = fract(g.x + 1/2), so the difference is
// (1 - u)(N1 - N0) + u (N2 - N1) over the three nodes N0..N2 around g.x, weighted bilinearly in
// y and z like the value: the 8 nodes of g's cell and one plane of 4 more per axis (-1 or +2).
// Within 1/2 node of the box's low faces and 2 of its high ones the difference is taken at the
// nearest point where the stencil's nodes exist, g clamped to [1/2, res - 2] in node units
// (MeshSDF.gradient and twins.sim.sdf_normal, the twins, do the same): the box is padded well past any contact margin, and a branch to a
// one-by-one fallback would cost its 48 texels everywhere on a software rasteriser (llvmpipe
// runs both sides of a branch for all its lanes: measured).
vec3 sdf_trilinear_diff(sampler3D tex, vec3 lo, float h, ivec3 res, vec3 x) {
    vec3 g = clamp((x - lo) / h, vec3(0.5), vec3(res - 2));
    ivec3 b = ivec3(floor(g));
    vec3 f = g - vec3(b);
    vec3 u = fract(g + 0.5);
    ivec3 s = ivec3(greaterThanEqual(f, vec3(0.5)));   // the three nodes start at b - 1 + s per axis
#define SDF_T(X, Y, Z) texelFetch(tex, ivec3(X, Y, Z), 0).r
#define SDF_D3(A, B, C) ((1.0 - U) * ((B) - (A)) + U * ((C) - (B)))
    float c000 = SDF_T(b.x, b.y, b.z), c100 = SDF_T(b.x + 1, b.y, b.z);
    float c010 = SDF_T(b.x, b.y + 1, b.z), c110 = SDF_T(b.x + 1, b.y + 1, b.z);
    float c001 = SDF_T(b.x, b.y, b.z + 1), c101 = SDF_T(b.x + 1, b.y, b.z + 1);
    float c011 = SDF_T(b.x, b.y + 1, b.z + 1), c111 = SDF_T(b.x + 1, b.y + 1, b.z + 1);
    int ex = s.x == 1 ? b.x + 2 : b.x - 1, ey = s.y == 1 ? b.y + 2 : b.y - 1, ez = s.z == 1 ? b.z + 2 : b.z - 1;
    float x00 = SDF_T(ex, b.y, b.z), x10 = SDF_T(ex, b.y + 1, b.z), x01 = SDF_T(ex, b.y, b.z + 1), x11 = SDF_T(ex, b.y + 1, b.z + 1);
    float y00 = SDF_T(b.x, ey, b.z), y10 = SDF_T(b.x + 1, ey, b.z), y01 = SDF_T(b.x, ey, b.z + 1), y11 = SDF_T(b.x + 1, ey, b.z + 1);
    float z00 = SDF_T(b.x, b.y, ez), z10 = SDF_T(b.x + 1, b.y, ez), z01 = SDF_T(b.x, b.y + 1, ez), z11 = SDF_T(b.x + 1, b.y + 1, ez);
    float U = u.x;   // x: (extra, c0, c1) below the cell's middle, (c0, c1, extra) above
    vec4 dx = s.x == 1 ? SDF_D3(vec4(c000, c010, c001, c011), vec4(c100, c110, c101, c111), vec4(x00, x10, x01, x11))
                       : SDF_D3(vec4(x00, x10, x01, x11), vec4(c000, c010, c001, c011), vec4(c100, c110, c101, c111));
    U = u.y;
    vec4 dy = s.y == 1 ? SDF_D3(vec4(c000, c100, c001, c101), vec4(c010, c110, c011, c111), vec4(y00, y10, y01, y11))
                       : SDF_D3(vec4(y00, y10, y01, y11), vec4(c000, c100, c001, c101), vec4(c010, c110, c011, c111));
    U = u.z;
    vec4 dz = s.z == 1 ? SDF_D3(vec4(c000, c100, c010, c110), vec4(c001, c101, c011, c111), vec4(z00, z10, z01, z11))
                       : SDF_D3(vec4(z00, z10, z01, z11), vec4(c000, c100, c010, c110), vec4(c001, c101, c011, c111));
#undef SDF_T
#undef SDF_D3
    // each vec4 holds the differences at the other two axes' nodes (0,0), (1,0), (0,1), (1,1): bilinear
    vec3 d;
    vec2 dxy = mix(dx.xz, dx.yw, f.y); d.x = mix(dxy.x, dxy.y, f.z);
    vec2 dyx = mix(dy.xz, dy.yw, f.x); d.y = mix(dyx.x, dyx.y, f.z);
    vec2 dzx = mix(dz.xz, dz.yw, f.x); d.z = mix(dzx.x, dzx.y, f.y);
    return d;
}
