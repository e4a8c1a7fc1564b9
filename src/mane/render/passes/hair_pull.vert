#version 430
// pipeline="compute": the hair by vertex pulling, no tessellation or geometry stage. One
// instance per rendered strand; its points come from strand_expand.comp's buffer.
// Ribbons: a triangle strip of 2 vertices per point, either side of the curve along
// cross(T, V), exactly hair.geom's corners (widened to u_min_pixel_width pixels, the
// coverage in g_alpha); GEOMETRY_LINES: a line strip through the points.
// VERTEX_SHADOWS: the lights' visibility at the strand point (both ribbon vertices of a point
// alike), interpolated along the segment (hair_radiance.glsl).
#if VERTEX_SHADOWS
#include "lighting.glsl"
out vec4 g_vis;
#endif
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
uniform int u_points_per_strand;

uniform mat4 u_view_proj;
uniform vec3 u_eye;           // perspective views: the eye
uniform vec3 u_view_dir;      // unit forward of the view
uniform int u_ortho;          // 1: orthographic (directional shadow views)
uniform float u_pixel_size;   // world size of a pixel at unit depth (perspective) or anywhere (ortho)
uniform float u_min_pixel_width;

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
out float g_across;           // -1 .. 1 across the ribbon along cross(T, V): h
out float g_width_px;         // the strand's true width in pixels (before widening)
#define NEAR_OUT(across, width) g_across = (across); g_width_px = (width)
#else
#define NEAR_OUT(across, width)
#endif

void main() {
#if GEOMETRY_LINES
    int j = gl_VertexID;
#else
    int j = gl_VertexID >> 1;
#endif
    int i = gl_InstanceID * u_points_per_strand + j;
    vec4 pw = expanded[2 * i];
    vec4 tr = expanded[2 * i + 1];
    vec3 P = pw.xyz;
    vec3 T = normalize(tr.xyz);
#if VERTEX_SHADOWS
    g_vis = light_visibilities(P);
#endif
    float a = 1.0;
    float depth = max(dot(P - u_eye, u_view_dir), 1e-4);
    float pixel = u_ortho != 0 ? u_pixel_size : u_pixel_size * depth;
    float w = pw.w;
    float width_px = w / pixel;
    float wmin = u_min_pixel_width * pixel;
    if (w < wmin) { a = w / wmin; w = wmin; }
#if !GEOMETRY_LINES
    vec3 V = u_ortho != 0 ? -u_view_dir : normalize(u_eye - P);
    vec3 side = cross(T, V);
    if (dot(side, side) < 1e-10) side = cross(T, abs(T.y) < 0.9 ? vec3(0, 1, 0) : vec3(1, 0, 0));
    side = normalize(side);
    P += ((gl_VertexID & 1) == 0 ? -0.5 : 0.5) * w * side;
    NEAR_OUT((gl_VertexID & 1) == 0 ? -1.0 : 1.0, width_px);
#else
    NEAR_OUT(0.0, 0.0);   // a line: no near field
#endif
    g_pos = P;
    g_tangent = T;
    g_s = float(j) / float(u_points_per_strand - 1);
    g_rand = tr.w;
    g_alpha = a;
    g_strand = gl_InstanceID;
    g_depth = dot(P - u_eye, u_view_dir);
    gl_Position = u_view_proj * vec4(P, 1.0);
    if (!(pw.w > 0.0)) gl_Position = vec4(0.0, 0.0, -2.0, 1.0);   // dropped by the LOD: clipped
}
