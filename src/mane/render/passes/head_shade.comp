#version 430
// The head's colour by compute (head_pass.py, the single-sample HDR target): the raster units
// drew only the head's depth and its nearest triangle's id (head.frag PASS 2); here a thread a
// pixel finds the point where the pixel centre's ray meets that triangle, interpolates the
// vertices' normal and scalp weight there (the rasteriser's perspective-correct interpolation),
// and writes head_radiance into the HDR colour. On an H200 a fragment shader runs on the few
// graphics units of a computing GPU (the 100k-strand 1080p close-up's head 0.76 ms).
#include "head_shading.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_HEAD_VERTICES) readonly buffer HeadVertices { float head_v[]; };   // position, normal, scalp
layout(std430, binding = B_HEAD_FACES) readonly buffer HeadFaces { uint head_f[]; };
layout(rgba16f, binding = IMG_HDR) writeonly uniform image2D u_hdr;
uniform sampler2D u_scene_depth;   // the head's window depth (1: none)
uniform usampler2D u_head_id;      // its triangle there
uniform mat4 u_head_model;
uniform mat4 u_inv_view_proj;
uniform ivec2 u_origin;             // the first pixel of the dispatch (the head's screen box)

vec3 head_vertex(uint v, int k) {
    return vec3(head_v[7u * v + uint(k)], head_v[7u * v + uint(k) + 1u], head_v[7u * v + uint(k) + 2u]);
}

void main() {
    ivec2 p = u_origin + ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(u_scene_depth, 0);
    if (p.x >= size.x || p.y >= size.y) return;
    if (!(texelFetch(u_scene_depth, p, 0).r < 1.0)) return;
    uint f = texelFetch(u_head_id, p, 0).r;
    uvec3 v = uvec3(head_f[3u * f], head_f[3u * f + 1u], head_f[3u * f + 2u]);
    vec3 a = (u_head_model * vec4(head_vertex(v.x, 0), 1.0)).xyz;
    vec3 b = (u_head_model * vec4(head_vertex(v.y, 0), 1.0)).xyz;
    vec3 c = (u_head_model * vec4(head_vertex(v.z, 0), 1.0)).xyz;
    // the pixel centre's ray: its points at the near and far planes
    vec2 ndc = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
    vec4 n0 = u_inv_view_proj * vec4(ndc, -1.0, 1.0), n1 = u_inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 o = n0.xyz / n0.w, d = n1.xyz / n1.w - o;
    vec3 e1 = b - a, e2 = c - a, nrm = cross(e1, e2);
    float den = dot(d, nrm);
    vec3 bary = vec3(1.0, 0.0, 0.0);   // a triangle edge on to the ray: its first vertex
    vec3 P = a;
    if (abs(den) > 1e-30) {
        P = o + d * (dot(a - o, nrm) / den);
        float n2 = dot(nrm, nrm);
        vec3 w = P - a;
        float l1 = dot(cross(w, e2), nrm) / n2, l2 = dot(cross(e1, w), nrm) / n2;
        // inside the triangle (a pixel at a silhouette seen edge on: the plane's point may lie
        // far off it, where the raster units' interpolation stays on it)
        bary = max(vec3(1.0 - l1 - l2, l1, l2), vec3(0.0));
        bary /= max(bary.x + bary.y + bary.z, 1e-30);
        P = bary.x * a + bary.y * b + bary.z * c;
    }
    mat3 nm = mat3(u_head_model);
    vec3 N = nm * (bary.x * head_vertex(v.x, 3) + bary.y * head_vertex(v.y, 3) + bary.z * head_vertex(v.z, 3));
    float scalp = dot(bary, vec3(head_v[7u * v.x + 6u], head_v[7u * v.y + 6u], head_v[7u * v.z + 6u]));
    imageStore(u_hdr, p, vec4(head_radiance(P, N, scalp), 1.0));
}
