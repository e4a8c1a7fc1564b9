#version 430
// Evaluate the curve, then move the strand off its guide: a disc perpendicular to the
// guide's tangent (in its transported frame), tapered at root and tip; a few strays.
#include "strand_common.glsl"
layout(isolines, equal_spacing) in;

in vec3 c_pos[];
in vec3 c_normal[];
patch in int p_guide;
patch in int p_seg;
patch in int p_first_strand;

uniform float u_clump_radius;
uniform float u_clump_root;
uniform float u_clump_tip;
uniform float u_stray_fraction;
uniform float u_stray_amount;
uniform int u_keep_guide;
uniform float u_width;
uniform float u_width_tip;

out vec3 e_pos;
out vec3 e_tangent;
out float e_s;        // 0 at the root .. 1 at the tip
out float e_rand;     // per strand, in [0,1)
out float e_width;    // metres
out float e_id;       // guide * strands_per_guide + strand (for tests)

void main() {
    float u = gl_TessCoord.x;
    int line = int(round(gl_TessCoord.y * gl_TessLevelOuter[0]));
    int strand = p_first_strand + line;
    vec3 P, D;
    eval_curve(c_pos[0], c_pos[1], c_pos[2], c_pos[3], u, P, D);
    vec3 T = length(D) > 1e-12 ? normalize(D) : normalize(c_pos[2] - c_pos[1] + 1e-9);
    float s = (float(p_seg) + u) / float(u_n - 1);

    uint seed = strand_seed(p_guide, strand);
    float r_radius = rand01(seed);
    float r_angle = rand01(seed);
    float r_stray = rand01(seed);
    float r_shape = rand01(seed);
    e_rand = rand01(seed);

    if (!(strand == 0 && u_keep_guide != 0)) {
        vec3 n = mix(c_normal[1], c_normal[2], u);
        n -= T * dot(n, T);
        if (dot(n, n) < 1e-12) {
            vec3 a = abs(T.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
            n = cross(cross(T, a), T);
        }
        n = normalize(n);
        vec3 b = cross(T, n);
        // quadratic taper: root fraction -> 1 (mid) -> tip fraction
        float profile = mix(mix(u_clump_root, 1.0, s), mix(1.0, u_clump_tip, s), s);
        float radius = u_clump_radius * sqrt(r_radius) * profile;
        if (r_stray < u_stray_fraction) {
            // strays after Rapp / the Vulkan hair: flyaway tips, a gradual drift, or a bulge
            float shape;
            if (r_shape < 0.4) shape = pow(s, 3.0);
            else if (r_shape < 0.75) shape = pow(s, 1.3);
            else shape = exp(-(s - 0.45) * (s - 0.45) / (2.0 * 0.2 * 0.2));
            radius += u_clump_radius * u_stray_amount * shape;
        }
        float angle = 6.28318530718 * r_angle;
        P += radius * (cos(angle) * n + sin(angle) * b);
    }
    e_pos = P;
    e_tangent = T;
    e_s = s;
    e_width = u_width * mix(1.0, u_width_tip, s);
    e_id = float(p_guide * u_strands_per_guide + strand);
}
