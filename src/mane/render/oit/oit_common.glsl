// Shared by the OIT fragment stages and resolves: colour packing, blending, fragment keys.
// Method ids (OIT_METHOD): 1 sorted blending, 2 random subsets, 3 A-buffer, 4 K-buffer,
// 5 DBK-buffer, 6 ShortCut. Colours are premultiplied linear RGB + alpha throughout.
#define OIT_END 0xFFFFFFFFu          // empty head pointer / empty 32-bit key
#define OIT_BEHIND 0x80000000u       // DBK: bit 31 of the front depth = hair behind the layer

uvec2 oit_pack(vec4 c) { return uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba)); }
vec4 oit_unpack(uvec2 u) { return vec4(unpackHalf2x16(u.x), unpackHalf2x16(u.y)); }

// front-to-back "under" blending of a premultiplied fragment
void oit_blend(inout vec3 C, inout float T, vec4 c) {
    C += T * c.rgb;
    T *= 1.0 - c.a;
}

// 24-bit quantised view depth in [near, far] (the hair's depth range this frame)
uint oit_depth24(float depth, vec2 range) {
    float t = clamp((depth - range.x) / max(range.y - range.x, 1e-12), 0.0, 1.0);
    return min(uint(t * 16777215.0 + 0.5), 16777215u);
}

// 40-bit colour (64-bit K-buffer): unpremultiplied r, g, b as 10-bit x/(1+x), alpha 10 bits
uvec2 oit_pack40(vec4 c) {   // .x: low 32 bits, .y: the top 8 bits (in its low byte)
    float a = clamp(c.a, 0.0, 1.0);
    vec3 rgb = a > 1e-6 ? max(c.rgb, vec3(0.0)) / a : vec3(0.0);
    uvec3 q = uvec3(clamp(rgb / (1.0 + rgb), 0.0, 1.0) * 1023.0 + 0.5);
    uint qa = uint(a * 1023.0 + 0.5);
    return uvec2(q.r | (q.g << 10) | (q.b << 20) | ((qa & 3u) << 30), qa >> 2);
}
vec4 oit_unpack40(uvec2 u) {
    vec3 e = vec3(u.x & 1023u, (u.x >> 10) & 1023u, (u.x >> 20) & 1023u) / 1023.0;
    float a = float((u.x >> 30) | ((u.y & 255u) << 2)) / 1023.0;
    vec3 rgb = e / max(1.0 - e, 1e-4);
    return vec4(rgb * a, a);
}
