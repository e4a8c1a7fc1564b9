// Density ray march (Woodhouse 2012, optimised_gpu): the extinction sigma (1/m) of the hair on
// a node grid in a 3D texture (node i at lo + i (hi - lo) / (R - 1), read trilinearly), marched
// from the shaded point toward light 0 until the box is left: T = exp(-u_shadow_density * tau),
// tau = integral of sigma ds (midpoint rule, u_density_step cells a step). sigma is the strands'
// cross-section per volume times their opacity: sum(width * length * strand_opacity) / cell volume.
// The box is a GridBounds buffer (the simulator's layout): lo at byte 32, hi at byte 48.
#if SHADOWS == 5
layout(std430, binding = B_DENSITY_BOX) readonly buffer DensityBox {
    int density_keys[8];
    vec4 density_lo;
    vec4 density_hi;
};
uniform sampler3D u_density;    // R32F sigma (1/m) at the nodes
uniform float u_density_step;   // cells per step

float density_tau(vec3 P, vec3 L, float start) {
    float R = float(textureSize(u_density, 0).x);
    vec3 lo = density_lo.xyz;
    vec3 ext = max(density_hi.xyz - lo, vec3(1e-9));
    vec3 cell = ext / (R - 1.0);
    // the ray P + t L leaves the box at t_exit
    vec3 inv = 1.0 / mix(L, vec3(1e-9), lessThan(abs(L), vec3(1e-9)));
    vec3 t0 = (lo - P) * inv, t1 = (lo + ext - P) * inv;
    float t_exit = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z));
    float ds = u_density_step * min(min(cell.x, cell.y), cell.z);
    float len = t_exit - start;
    if (len <= 0.0) return 0.0;
    int steps = min(int(ceil(len / ds)), 4096);
    ds = len / float(steps);
    float tau = 0.0;
    for (int i = 0; i < steps; ++i) {
        vec3 X = P + (start + (float(i) + 0.5) * ds) * L;
        vec3 uvw = ((X - lo) / ext * (R - 1.0) + 0.5) / R;
        tau += texture(u_density, uvw).r;
    }
    return tau * ds;
}

float density_transmittance(vec3 P) {
    float falloff;
    vec3 L = light_dir_at(0, P, falloff);
    return exp(-u_shadow_density * density_tau(P, L, u_shadow_bias));
}
#endif
