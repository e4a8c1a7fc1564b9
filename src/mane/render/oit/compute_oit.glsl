// What the compute OIT dispatches share (oit/compute.py): the expanded strands, the camera's
// raster view (passes/raster_view.glsl, one sample per pixel), window depth -> view depth, and
// (with OIT_SHADING) a fragment's premultiplied colour.
//
// A fragment is (pixel, segment): the samples raster_segment.glsl gives a segment (at most one
// per pixel). Its depth is the window depth interpolated along the segment on screen (the
// value the scan conversion hands RASTER_VISIT), its key the depth's float bits (ascending
// with depth: all >= 0) over the segment id, its alpha clamp(coverage x u_oit_opacity), and its
// colour the hair BSDF (passes/hair_radiance.glsl) at the segment's point nearest the pixel
// centre (perspective-correct), as the opaque compute rasteriser shades it.
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
uniform int u_points_per_strand;
uniform float u_oit_opacity;   // strand opacity in the camera view (x coverage)
uniform vec3 u_oit_lin;        // x 1: perspective, depth = z / (ndc - y); 0: ortho, depth = (ndc - y) / z
#include "passes/raster_view.glsl"

#define OIT_EMPTY 0xFFFFFFFFu
#ifndef OIT_TAIL_SHADED
#define OIT_TAIL_SHADED 1
#endif
// the tail's words (word-major: word w of pixel p at w * pixels + p)
#if OIT_TAIL_SHADED
#define TW_R 0u
#define TW_G 1u
#define TW_B 2u
#define TW_A 3u
#define TW_OPT 4u
#define TW_N 5u
#define TW_WORDS 6u
#else
#define TW_A 0u
#define TW_OPT 1u
#define TW_N 2u
#define TW_WORDS 3u
#endif
#define OIT_SCALE 4096.0           // fixed point of the atomic sums (colour, alpha, optical depth)

// view depth (m along the camera axis) of a window depth
float oit_view_depth(float window_z) {
    float ndc = 2.0 * window_z - 1.0;
    return u_oit_lin.x > 0.5 ? u_oit_lin.z / (ndc - u_oit_lin.y) : (ndc - u_oit_lin.y) / u_oit_lin.z;
}

uint oit_pixel_index(ivec2 q) { return uint(q.y) * uint(u_raster_size.x) + uint(q.x); }
uint oit_num_pixels() { return uint(u_raster_size.x) * uint(u_raster_size.y); }

float oit_alpha_of(float coverage) { return clamp(coverage * u_oit_opacity, 0.0, 1.0); }

// -log(1 - alpha) in 1/OIT_SCALE units (transmittance products as atomic sums)
uint oit_optical_units(float a) { return uint(-log(1.0 - clamp(a, 0.0, 0.9999)) * OIT_SCALE + 0.5); }
uint oit_units(float v) { return uint(max(v, 0.0) * OIT_SCALE + 0.5); }

struct OitSegment {
    vec4 p0, t0, p1, t1;
    RasterPoint a, b;
};

OitSegment oit_segment(uint i) {
    OitSegment s;
    s.p0 = expanded[2u * i];
    s.t0 = expanded[2u * i + 1u];
    s.p1 = expanded[2u * i + 2u];
    s.t1 = expanded[2u * i + 3u];
    s.a = raster_point(s.p0.xyz, s.p0.w);
    s.b = raster_point(s.p1.xyz, s.p1.w);
    return s;
}

// the coverage raster_segment.glsl interpolates at pixel q: linear along the major axis
float oit_coverage(OitSegment s, ivec2 q) {
    vec2 d = s.b.s - s.a.s;
    bool steep = abs(d.y) > abs(d.x);
    float num = steep ? float(q.y) + 0.5 - s.a.s.y : float(q.x) + 0.5 - s.a.s.x;
    float den = steep ? d.y : d.x;
    float t = clamp(num / (abs(den) > 1e-12 ? den : 1e-12), 0.0, 1.0);
    return mix(s.a.coverage, s.b.coverage, t);
}

#if OIT_SHADING
// premultiplied colour and alpha of segment i's fragment at pixel q
vec4 oit_shade(uint i, ivec2 q) {
    OitSegment s = oit_segment(i);
    float a = oit_alpha_of(oit_coverage(s, q));
    float t = raster_param(s.a, s.b, vec2(q) + 0.5);
#if HAIR_NEAR_FIELD
    vec2 across = raster_across(s.a, s.b, vec2(q) + 0.5);
    hair_set_near(across.x, across.y);
#endif
    vec3 P = mix(s.p0.xyz, s.p1.xyz, t);
    vec3 T = normalize(mix(s.t0.xyz, s.t1.xyz, t));
    float j = float(i % uint(u_points_per_strand));
    vec3 c = hair_radiance(P, T, u_eye, (j + t) / float(u_points_per_strand - 1), s.t0.w);
    return vec4(max(c, vec3(0.0)) * a, a);
}
#endif
