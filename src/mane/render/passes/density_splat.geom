#version 430
// Density splat: every rendered segment (from hair.tese) is sampled at about half-cell steps;
// each sample adds its alpha-weighted cross-section w ds alpha / cell volume (sigma, 1/m) to the
// 8 nodes around it with trilinear (tent) weights, atomically in fixed point. Emits nothing.
layout(lines) in;
layout(points, max_vertices = 1) out;

in vec3 e_pos[];
in float e_width[];

layout(std430, binding = B_DENSITY_ACC) coherent buffer DensityAccumulator { uint density_acc[]; };
layout(std430, binding = B_DENSITY_BOX) readonly buffer DensityBox {
    int density_keys[8];
    vec4 density_lo;
    vec4 density_hi;
};
uniform float u_strand_opacity;

void add_node(ivec3 n, float v) {
    if (v <= 0.0) return;
    uint q = uint(v * FIXED_SCALE + 0.5);
    if (q != 0u) atomicAdd(density_acc[n.x + DENSITY_RES * (n.y + DENSITY_RES * n.z)], q);
}

void main() {
    vec3 lo = density_lo.xyz;
    vec3 ext = max(density_hi.xyz - lo, vec3(1e-9));
    vec3 cell = ext / float(DENSITY_RES - 1);
    float volume = cell.x * cell.y * cell.z;
    float h = min(min(cell.x, cell.y), cell.z);
    vec3 d = e_pos[1] - e_pos[0];
    float len = length(d);
    int n = clamp(int(ceil(len / (0.5 * h))), 1, 64);
    float ds = len / float(n);
    for (int k = 0; k < n; ++k) {
        float t = (float(k) + 0.5) / float(n);
        vec3 P = e_pos[0] + t * d;
        float w = mix(e_width[0], e_width[1], t);
        float sigma = w * ds * u_strand_opacity / volume;
        vec3 g = clamp((P - lo) / ext * float(DENSITY_RES - 1), vec3(0.0), vec3(float(DENSITY_RES - 1)));
        ivec3 b = min(ivec3(floor(g)), ivec3(DENSITY_RES - 2));
        vec3 f = g - vec3(b);
        for (int c = 0; c < 8; ++c) {
            ivec3 o = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
            vec3 wt = mix(vec3(1.0) - f, f, vec3(o));
            add_node(b + o, sigma * wt.x * wt.y * wt.z);
        }
    }
}
