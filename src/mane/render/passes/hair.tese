#version 430
// Evaluate the curve, then move the strand off its guide.
//   single (MULTI 0): a disc perpendicular to the guide's tangent (in its transported frame),
//     tapered at root and tip (Chen's single-strand interpolation);
//   multi (MULTI 1): the barycentric blend of 3 guide curves plus the strand's root offset
//     (Woodhouse); hybrid (MULTI 2): multi, or for a flagged strand (its guides straddle a
//     collider) the single-strand form: its heaviest guide plus its root offset carried in
//     that guide's frame.
// Then every strand: deviation with probability u_stray_fraction in one of five equiprobable
// shapes (Vulkan hair after Rapp 2014; twins in mane/render/strand_math.py), render-time curl
// (a helix around the curve), distance LOD (width multiplier, fading strands).
#include "strand_common.glsl"
#if LOD
layout(isolines, fractional_odd_spacing) in;
#else
layout(isolines, equal_spacing) in;
#endif

in vec3 c_pos[];
in vec3 c_normal[];
patch in int p_guide;
patch in int p_seg;
patch in int p_first_strand;
patch in float p_lod_count;
patch in float p_lod_t;

uniform float u_clump_radius;
uniform float u_clump_root;
uniform float u_clump_tip;
uniform float u_stray_fraction;
uniform float u_stray_amount;
uniform int u_keep_guide;
uniform float u_width;
uniform float u_width_tip;
uniform float u_curl_radius;
uniform float u_curl_frequency;

out vec3 e_pos;
out vec3 e_tangent;
out float e_s;        // 0 at the root .. 1 at the tip
out float e_rand;     // per strand, in [0,1)
out float e_width;    // metres
out float e_id;       // guide * strands_per_guide + strand (MULTI: the record index)
out float e_lod_alpha;// LOD fade of the strand (1 kept, 0 dropped)

// The five deviation shapes, peak 1 over all of them (4.5 s^10 at the tip).
float stray_profile(int k, float s) {
    float g25 = exp(-(s - 0.25) * (s - 0.25) / 0.08);
    float g70 = exp(-(s - 0.70) * (s - 0.70) / 0.08);
    float g80 = exp(-(s - 0.80) * (s - 0.80) / 0.08);
    float v;
    if (k == 0) v = 1.8 * g25;                 // a Gaussian near the root
    else if (k == 1) v = 2.5 * g70;            // a lower Gaussian
    else if (k == 2) v = 1.8 * g80;            // a lower Gaussian, another scale
    else if (k == 3) v = 4.5 * pow(s, 10.0);   // a sharp exponential: flyaway tips
    else v = 4.0 * pow(s, 1.3);                // a gradual exponential
    return v / 4.5;
}

vec3 frame_normal(vec3 n, vec3 T) {
    n -= T * dot(n, T);
    if (dot(n, n) < 1e-12) {
        vec3 a = abs(T.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
        n = cross(cross(T, a), T);
    }
    return normalize(n);
}

void main() {
    float u = gl_TessCoord.x;
    int line = int(round(gl_TessCoord.y * gl_TessLevelOuter[0]));
    int strand = p_first_strand + line;
    float s = (float(p_seg) + u) / float(u_n - 1);
    vec3 P, D, n;
    float lod_t_strand = p_lod_t;
    bool disc = true;           // single-strand clump disc
#if MULTI
    StrandRecord rec = strand_table[strand];
    int g0 = rec.guides.x;
    uint seed = strand_seed(g0, strand);
    int k0 = p_seg - 1;
    vec3 Pi, Di;
    P = vec3(0.0); D = vec3(0.0); n = vec3(0.0);
    vec3 root = rec.offset.xyz;
    for (int i = 0; i < 3; ++i) {
        int g = rec.guides[i];
        float w = rec.weights[i];
        eval_curve(guide_point(g, k0), guide_point(g, k0 + 1), guide_point(g, k0 + 2), guide_point(g, k0 + 3),
                   u, Pi, Di);
        P += w * Pi;
        D += w * Di;
        n += w * mix(guide_normal(g, p_seg), guide_normal(g, p_seg + 1), u);
        root += w * guide_point(g, 0);
    }
    P += rec.offset.xyz;
    disc = false;
#if MULTI == 2
    if ((rec.guides.w & 1) != 0) {
        // single-strand form around the heaviest guide: the root offset in its root frame
        // (n, b, t), carried along in its transported frame and tapered by u_clump_tip
        vec3 r0 = guide_point(g0, 0);
        vec3 t0 = normalize(guide_point(g0, 1) - r0 + 1e-12);
        vec3 n0 = frame_normal(guide_normal(g0, 0), t0);
        vec3 b0 = cross(t0, n0);
        vec3 o = root - r0;
        vec3 ab = vec3(dot(o, n0), dot(o, b0), dot(o, t0));
        eval_curve(guide_point(g0, k0), guide_point(g0, k0 + 1), guide_point(g0, k0 + 2), guide_point(g0, k0 + 3),
                   u, P, D);
        vec3 Tg = length(D) > 1e-12 ? normalize(D) : t0;
        vec3 ng = frame_normal(mix(guide_normal(g0, p_seg), guide_normal(g0, p_seg + 1), u), Tg);
        n = ng;
        P += mix(1.0, u_clump_tip, s) * (ab.x * ng + ab.y * cross(Tg, ng) + ab.z * Tg);
    }
#endif
#if LOD
    lod_t_strand = lod_t(root);
#endif
#else
    uint seed = strand_seed(p_guide, strand);
    eval_curve(c_pos[0], c_pos[1], c_pos[2], c_pos[3], u, P, D);
    n = mix(c_normal[1], c_normal[2], u);
    if (strand == 0 && u_keep_guide != 0) disc = false;
#endif
    vec3 T = length(D) > 1e-12 ? normalize(D) : normalize(c_pos[2] - c_pos[1] + 1e-9);

    float r_radius = rand01(seed);
    float r_angle = rand01(seed);
    float r_stray = rand01(seed);
    float r_shape = rand01(seed);
    e_rand = rand01(seed);
    float r_curl = rand01(seed);
    float r_lod = rand01(seed);

    n = frame_normal(n, T);
    vec3 b = cross(T, n);
    float radius = 0.0;
    if (disc) {
        // quadratic taper: root fraction -> 1 (mid) -> tip fraction
        float profile = mix(mix(u_clump_root, 1.0, s), mix(1.0, u_clump_tip, s), s);
        radius = u_clump_radius * sqrt(r_radius) * profile;
    }
    bool keep = !(MULTI == 0 && strand == 0 && u_keep_guide != 0);
    if (keep && r_stray < u_stray_fraction)
        radius += u_clump_radius * u_stray_amount * stray_profile(min(int(r_shape * 5.0), 4), s);
    float angle = 6.28318530718 * r_angle;
    P += radius * (cos(angle) * n + sin(angle) * b);

    if (u_curl_radius > 0.0) {
        // a helix around the curve: radius ramps in over the first 10% (the root stays put)
        float th = 6.28318530718 * (u_curl_frequency * s + r_curl);
        float x = clamp(s / 0.1, 0.0, 1.0);
        float ramp = x * x * (3.0 - 2.0 * x);
        float dramp = s < 0.1 ? 6.0 * x * (1.0 - x) / 0.1 : 0.0;
        vec3 radial = cos(th) * n + sin(th) * b;
        vec3 around = -sin(th) * n + cos(th) * b;
        P += u_curl_radius * ramp * radial;
        vec3 dPds = D * float(u_n - 1) + u_curl_radius * (dramp * radial + ramp * 6.28318530718 * u_curl_frequency * around);
        if (dot(dPds, dPds) > 1e-20) T = normalize(dPds);
    }

    float lod_alpha = 1.0;
#if LOD
#if MULTI
    float density = mix(1.0, u_lod_range.z, lod_t_strand);
    lod_alpha = clamp((density - r_lod * (1.0 - 0.05)) / 0.05, 0.0, 1.0);
#else
    lod_alpha = (strand == 0 && u_keep_guide != 0) ? 1.0 : clamp(p_lod_count - float(strand), 0.0, 1.0);
#endif
#endif
    e_lod_alpha = lod_alpha;
    e_pos = P;
    e_tangent = T;
    e_s = s;
    e_width = u_width * mix(1.0, u_width_tip, s) * mix(1.0, u_lod_range.w, lod_t_strand);
#if MULTI
    e_id = float(strand);
#else
    e_id = float(p_guide * u_strands_per_guide + strand);
#endif
}
