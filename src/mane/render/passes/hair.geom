#version 430
// Each tessellated segment becomes a ribbon: at both ends two vertices either side of the curve
// along side = cross(T, V), perpendicular to the tangent T and to the view direction V, so the
// strip contains the curve and turns its face to the viewer as much as such a strip can. Widths below u_min_pixel_width pixels are
// widened to it, and the fragment's alpha carries the true coverage (true width / drawn width).
// GEOMETRY_LINES: a GL line strip instead (the baseline).
// VERTEX_SHADOWS: the lights' visibility at both ends of the segment, interpolated along it.
layout(lines) in;
#if GEOMETRY_LINES
layout(line_strip, max_vertices = 2) out;
#else
layout(triangle_strip, max_vertices = 4) out;
#endif

in vec3 e_pos[];
in vec3 e_tangent[];
in float e_s[];
in float e_rand[];
in float e_width[];
in float e_id[];
in float e_lod_alpha[];   // distance LOD fade (0: the strand is dropped)

uniform mat4 u_view_proj;
uniform vec3 u_eye;           // perspective views: the eye
uniform vec3 u_view_dir;      // unit forward of the view
uniform int u_ortho;          // 1: orthographic (directional shadow views)
uniform float u_pixel_size;   // world size of a pixel at unit depth (perspective) or anywhere (ortho)
uniform float u_min_pixel_width;

#if VERTEX_SHADOWS
#include "lighting.glsl"
out vec4 g_vis;
#endif
out vec3 g_pos;
out vec3 g_tangent;
out float g_s;
out float g_rand;
out float g_alpha;
out float g_depth;            // view depth (m) along u_view_dir
flat out int g_strand;        // the rendered strand (the MSAA coverage mask's seed)
invariant gl_Position;        // the depth pre-pass and the shading pass meet at equal depths
#ifndef HAIR_NEAR_FIELD
#define HAIR_NEAR_FIELD 0
#endif
#if HAIR_NEAR_FIELD   // the near field's inputs (shading/hair_shading.glsl's hair_set_near)
out float g_across;           // -1 .. 1 across the drawn ribbon along cross(T, V): h
out float g_width_px;         // the strand's true width in pixels (before widening)
#define NEAR_OUT(across, width) g_across = (across); g_width_px = (width)
#else
#define NEAR_OUT(across, width)
#endif

#if CAPTURE
// Test hook: every emitted segment appended to a buffer (8 vec4 per segment).
layout(std430, binding = B_CAPTURE) buffer Capture { uint capture_count; uint capture_pad[3]; vec4 capture[]; };
uniform int u_capture_max;
#endif

void main() {
    if (e_lod_alpha[0] <= 0.0 && e_lod_alpha[1] <= 0.0) return;   // LOD: dropped strand
    vec3 corner[4];
    float alpha[2];
    float width_px[2];
#if VERTEX_SHADOWS
    vec4 vis[2] = vec4[2](light_visibilities(e_pos[0]), light_visibilities(e_pos[1]));
#endif
    for (int i = 0; i < 2; ++i) {
        vec3 P = e_pos[i];
        vec3 T = normalize(e_tangent[i]);
        vec3 V = u_ortho != 0 ? -u_view_dir : normalize(u_eye - P);
        vec3 side = cross(T, V);
        if (dot(side, side) < 1e-10) side = cross(T, abs(T.y) < 0.9 ? vec3(0, 1, 0) : vec3(1, 0, 0));
        side = normalize(side);
        float depth = max(dot(P - u_eye, u_view_dir), 1e-4);
        float pixel = u_ortho != 0 ? u_pixel_size : u_pixel_size * depth;
        float w = e_width[i];
        width_px[i] = w / pixel;
        float a = 1.0;
        float wmin = u_min_pixel_width * pixel;
        if (w < wmin) { a = w / wmin; w = wmin; }
        alpha[i] = a * e_lod_alpha[i];
        corner[2 * i] = P - 0.5 * w * side;
        corner[2 * i + 1] = P + 0.5 * w * side;
    }
#if CAPTURE
    uint slot = atomicAdd(capture_count, 1u);
    if (slot < uint(u_capture_max)) {
        uint b = slot * 8u;
        capture[b + 0u] = vec4(e_pos[0], e_s[0]);
        capture[b + 1u] = vec4(e_pos[1], e_s[1]);
        capture[b + 2u] = vec4(e_tangent[0], e_id[0]);
        capture[b + 3u] = vec4(e_tangent[1], alpha[0]);
        for (int c = 0; c < 4; ++c) capture[b + 4u + uint(c)] = vec4(corner[c], e_width[c / 2]);
    }
#endif
    for (int i = 0; i < 2; ++i) {
        g_tangent = normalize(e_tangent[i]);
        g_s = e_s[i];
        g_rand = e_rand[i];
        g_alpha = alpha[i];
        g_strand = int(e_id[0]);
#if VERTEX_SHADOWS
        g_vis = vis[i];
#endif
#if GEOMETRY_LINES
        g_pos = e_pos[i];
        NEAR_OUT(0.0, 0.0);   // a line: no near field
        g_depth = dot(g_pos - u_eye, u_view_dir);
        gl_Position = u_view_proj * vec4(g_pos, 1.0);
        EmitVertex();
#else
        for (int j = 0; j < 2; ++j) {
            g_pos = corner[2 * i + j];
            NEAR_OUT(j == 0 ? -1.0 : 1.0, width_px[i]);
            g_depth = dot(g_pos - u_eye, u_view_dir);
            gl_Position = u_view_proj * vec4(g_pos, 1.0);
            EmitVertex();
        }
#endif
    }
    EndPrimitive();
}
