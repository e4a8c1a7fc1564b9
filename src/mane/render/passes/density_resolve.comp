#version 430
// The density texture (sigma, 1/m, per node) from
//   FROM_GRID 0: the splat's fixed-point sums (then cleared for the next frame);
//   FROM_GRID 1: the simulator's friction grid (vec4(velocity, mass) per node), mass scaled by
//                u_area_per_mass (alpha-weighted strand area per unit of mass) / cell volume.
// Node (x, y, z) is element x + R (y + R z) of the buffers and texel (x, y, z) of the texture.
layout(local_size_x = 64) in;
layout(r32f, binding = IMG_DENSITY) writeonly uniform image3D u_out;
#if FROM_GRID
layout(std430, binding = B_SIM_GRID) readonly buffer Grid { vec4 grid[]; };
layout(std430, binding = B_DENSITY_BOX) readonly buffer DensityBox {
    int density_keys[8];
    vec4 density_lo;
    vec4 density_hi;
};
uniform float u_area_per_mass;
#else
layout(std430, binding = B_DENSITY_ACC) buffer DensityAccumulator { uint density_acc[]; };
#endif

void main() {
    uint i = gl_GlobalInvocationID.x;
    const uint R = uint(DENSITY_RES);
    if (i >= R * R * R) return;
    ivec3 n = ivec3(int(i % R), int((i / R) % R), int(i / (R * R)));
#if FROM_GRID
    vec3 cell = max(density_hi.xyz - density_lo.xyz, vec3(1e-9)) / float(R - 1u);
    float sigma = max(grid[i].w, 0.0) * u_area_per_mass / (cell.x * cell.y * cell.z);
#else
    float sigma = float(density_acc[i]) / FIXED_SCALE;
    density_acc[i] = 0u;
#endif
    imageStore(u_out, n, vec4(sigma));
}
