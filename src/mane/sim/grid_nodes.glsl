// Node grid of GRID_RES^3 nodes spanning the GridBounds box: node i sits at lo + i * (hi - lo) / (R - 1).
// A point's trilinear (tent) stencil is the 8 nodes of the cell that holds it; points outside
// the box are clamped onto it.
#include "grid_bounds.glsl"

struct NodeStencil {
    ivec3 base;   // lower corner node, each in [0, R-2]
    vec3 frac;    // position inside the cell, in [0, 1]
};

NodeStencil node_stencil(vec3 p) {
    vec3 lo = bounds_lo.xyz;
    vec3 extent = max(bounds_hi.xyz - lo, vec3(1e-30));
    vec3 g = clamp((p - lo) / extent * float(GRID_RES - 1), vec3(0.0), vec3(float(GRID_RES - 1)));
    NodeStencil s;
    s.base = min(ivec3(floor(g)), ivec3(GRID_RES - 2));
    s.frac = g - vec3(s.base);
    return s;
}

float corner_weight(vec3 f, ivec3 c) {
    vec3 w = mix(vec3(1.0) - f, f, vec3(c));
    return w.x * w.y * w.z;
}

uint node_index(ivec3 n) {
    return uint(n.x + GRID_RES * (n.y + GRID_RES * n.z));
}

// the mass a particle brings: 1/w, or PINNED_MASS for pinned particles (w = 0), in mass units
float particle_mass(float inverse_mass, float pinned_mass, float inv_mass_unit) {
    return (inverse_mass > 0.0 ? 1.0 / inverse_mass : pinned_mass) * inv_mass_unit;
}
