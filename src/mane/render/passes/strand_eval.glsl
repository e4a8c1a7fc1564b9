// A rendered strand's point: the guide curve evaluated, moved off its guide. Shared by the
// tessellation evaluation stage (hair.tese) and the compute expansion (strand_expand.comp).
//   single (MULTI 0): a disc perpendicular to the guide's tangent (in its transported frame),
//     tapered at root and tip (Chen's single-strand interpolation);
//   multi (MULTI 1): the barycentric blend of 3 guide curves plus the strand's root offset
//     (Woodhouse); hybrid (MULTI 2): multi, or for a flagged strand (its guides straddle a
//     collider) the single-strand form: its heaviest guide plus its root offset carried in
//     that guide's frame.
// Then every strand: deviation with probability u_stray_fraction in one of five equiprobable
// shapes (Vulkan hair after Rapp 2014; twins in mane/render/strand_math.py), render-time curl
// (a helix around the curve), distance LOD (width multiplier, fading strands). The tangent here
// is the strand's own as far as its offsets' lengths go (the clump's taper, a stray, the curl
// differentiated), but not the turning of the guide's frame that carries them: a strand an
// offset r off a guide bent with curvature k moves at (1 - k r cos) times the guide's pace, and
// where k r > 1 (tight curls) backwards. So the callers replace it with the direction of the
// strand's drawn points, strand_curve_tangent (central differences: strand_expand.comp from its
// neighbours, hair.tese from the curve evaluated a step either side), and then tilt it per strand
// by u_strand_spread (strand_tilted). Needs strand_common.glsl first.

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
uniform float u_strand_spread;   // radians: RMS tilt of a strand's direction (shading tangent)

struct StrandVertex {
    vec3 pos;
    vec3 tangent;
    float s;          // 0 at the root .. 1 at the tip
    float rand;       // per strand, in [0,1)
    float width;      // metres
    float id;         // guide * strands_per_guide + strand (MULTI: the record index)
    float lod_alpha;  // LOD fade of the strand (1 kept, 0 dropped)
    vec3 n;           // the guide's frame normal here (the tilt's reference direction)
    float tilt;       // the strand's tilt of its shading tangent (radians; 0: none)
    float tilt_phi;   // its direction about the tangent
};

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

// How far a strand sits from its guide at s: the clump disc's radius (quadratic taper: root
// fraction -> 1 (mid) -> tip fraction) plus a stray's deviation.
float offset_radius(float s, bool disc, bool stray, float r_radius, float r_shape) {
    float radius = 0.0;
    if (disc) {
        float profile = mix(mix(u_clump_root, 1.0, s), mix(1.0, u_clump_tip, s), s);
        radius = u_clump_radius * sqrt(r_radius) * profile;
    }
    if (stray) radius += u_clump_radius * u_stray_amount * stray_profile(min(int(r_shape * 5.0), 4), s);
    return radius;
}

vec3 frame_normal(vec3 n, vec3 T) {
    n -= T * dot(n, T);
    if (dot(n, n) < 1e-12) {
        vec3 a = abs(T.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
        n = cross(cross(T, a), T);
    }
    return normalize(n);
}

// The shading tangent at a point whose neighbours along the drawn strand are a (before) and b
// (after), either of them the point itself at an end: their direction, or `fallback` where
// they lie within 1e-5 of their distance from the origin (float32's round-off a few hundred times
// over): the points of a collapsed LOD segment, equal but for the round-off of two cubics.
vec3 strand_curve_tangent(vec3 a, vec3 b, vec3 fallback) {
    vec3 d = b - a;
    float scale = 1e-5 * max(max(length(a), length(b)), 1e-3);
    return dot(d, d) > scale * scale ? normalize(d) : fallback;
}

// T tilted by the strand's spread (strand_eval's tilt, tilt_phi; unchanged where there is none):
// fibres of a clump are not parallel copies, each strand's direction tilts from its curve's by
// a random angle (Rayleigh, RMS u_strand_spread radians) in a random direction turning twice
// along the strand, so that a clump's strands catch the highlight at different places along
// it instead of all at once as one flat reflector
vec3 strand_tilted(vec3 T, StrandVertex v) {
    if (v.tilt <= 0.0) return T;
    vec3 nt = frame_normal(v.n, T);
    return normalize(T + tan(min(v.tilt, 1.2)) * (cos(v.tilt_phi) * nt + sin(v.tilt_phi) * cross(T, nt)));
}

// guide (single) and seg: the guide segment; u in [0,1] along it; strand: the strand of the
// guide (single) or the record (MULTI). cp0..cp3: the guide's points seg-1..seg+2 and cn1, cn2
// its frame normals at seg, seg+1 (single; unused with MULTI). lod_count, lod_t_patch: the
// strands kept of this guide and the guide's LOD parameter (LOD).
StrandVertex strand_eval(int guide, int seg, float u, int strand, float lod_count, float lod_t_patch,
                         vec3 cp0, vec3 cp1, vec3 cp2, vec3 cp3, vec3 cn1, vec3 cn2) {
    float s = (float(seg) + u) / float(u_n - 1);
    vec3 P, D, n;
    float lod_t_strand = lod_t_patch;
    bool disc = true;           // single-strand clump disc
#if MULTI
    StrandRecord rec = strand_table[strand];
    int g0 = rec.guides.x;
    uint seed = strand_seed(g0, strand);
    int k0 = seg - 1;
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
        n += w * mix(guide_normal(g, seg), guide_normal(g, seg + 1), u);
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
        vec3 ng = frame_normal(mix(guide_normal(g0, seg), guide_normal(g0, seg + 1), u), Tg);
        n = ng;
        P += mix(1.0, u_clump_tip, s) * (ab.x * ng + ab.y * cross(Tg, ng) + ab.z * Tg);
    }
#endif
#if LOD
    lod_t_strand = lod_t(root);
#endif
#else
    uint seed = strand_seed(guide, strand);
    eval_curve(cp0, cp1, cp2, cp3, u, P, D);
    n = mix(cn1, cn2, u);
    if (strand == 0 && u_keep_guide != 0) disc = false;
#endif
    vec3 T = length(D) > 1e-12 ? normalize(D) : normalize(cp2 - cp1 + 1e-9);

    float r_radius = rand01(seed);
    float r_angle = rand01(seed);
    float r_stray = rand01(seed);
    float r_shape = rand01(seed);
    float strand_rand = rand01(seed);
    float r_curl = rand01(seed);
    float r_lod = rand01(seed);
    float r_tilt = rand01(seed);
    float r_tilt_dir = rand01(seed);

    n = frame_normal(n, T);
    vec3 b = cross(T, n);
    bool keep = !(MULTI == 0 && strand == 0 && u_keep_guide != 0);
    bool stray = keep && r_stray < u_stray_fraction;
    float radius = offset_radius(s, disc, stray, r_radius, r_shape);
    float angle = 6.28318530718 * r_angle;
    vec3 dir = cos(angle) * n + sin(angle) * b;
    P += radius * dir;
    // the strand's own direction, not its guide's: the guide's derivative plus the change of the
    // offset along the strand (the clump's taper, a stray leaving its clump)
    const float ds = 1e-3;
    float dr = (offset_radius(s + ds, disc, stray, r_radius, r_shape)
              - offset_radius(s - ds, disc, stray, r_radius, r_shape)) / (2.0 * ds);
    vec3 dPds = D * float(u_n - 1) + dr * dir;
    if (dot(dPds, dPds) > 1e-20) T = normalize(dPds);

    if (u_curl_radius > 0.0) {
        // a helix around the curve: radius ramps in over the first 10% (the root stays put)
        float th = 6.28318530718 * (u_curl_frequency * s + r_curl);
        float x = clamp(s / 0.1, 0.0, 1.0);
        float ramp = x * x * (3.0 - 2.0 * x);
        float dramp = s < 0.1 ? 6.0 * x * (1.0 - x) / 0.1 : 0.0;
        vec3 radial = cos(th) * n + sin(th) * b;
        vec3 around = -sin(th) * n + cos(th) * b;
        P += u_curl_radius * ramp * radial;
        dPds += u_curl_radius * (dramp * radial + ramp * 6.28318530718 * u_curl_frequency * around);
        if (dot(dPds, dPds) > 1e-20) T = normalize(dPds);
    }
    // the strand's tilt (strand_tilted applies it to the tangent the caller settles on)
    float tilt = keep && u_strand_spread > 0.0 ? u_strand_spread * sqrt(-log(max(1.0 - r_tilt, 1e-7))) : 0.0;
    float tilt_phi = 6.28318530718 * (r_tilt_dir + 2.0 * s);   // turning twice along the strand

    float lod_alpha = 1.0;
#if LOD
#if MULTI
    float density = mix(1.0, u_lod_range.z, lod_t_strand);
    lod_alpha = clamp((density - r_lod * (1.0 - 0.05)) / 0.05, 0.0, 1.0);
#else
    lod_alpha = (strand == 0 && u_keep_guide != 0) ? 1.0 : clamp(lod_count - float(strand), 0.0, 1.0);
#endif
#endif
    StrandVertex v;
    v.rand = strand_rand;
    v.lod_alpha = lod_alpha;
    v.pos = P;
    v.tangent = T;
    v.n = n;
    v.tilt = tilt;
    v.tilt_phi = tilt_phi;
    v.s = s;
    v.width = u_width * mix(1.0, u_width_tip, s) * mix(1.0, u_lod_range.w, lod_t_strand);
#if MULTI
    v.id = float(strand);
#else
    v.id = float(guide * u_strands_per_guide + strand);
#endif
    return v;
}
