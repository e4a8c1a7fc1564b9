#version 430
// The skin bounce's grid (skin_bounce.py; base.SKIN_BOUNCE_GRID): skin_bounce.glsl's gather evaluated at the centre
// of every cell, once a frame after the reflective shadow map is built. Cell (i, j, k) of the
// u_grid_size grid stands for the point of light 0's view at map coordinates and light depth
// u_bounce_grid_lo + ((i, j, k) + 1/2) / u_grid_size / u_bounce_grid_inv (the hair's footprint
// and depth range); the shaded points read it trilinear (skin_bounce_grid).
#include "common.glsl"
#include "lighting.glsl"
#include "skin_bounce.glsl"
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba16f, binding = IMG_BOUNCE_GRID) writeonly uniform image3D u_grid_out;
uniform ivec3 u_grid_size;

void main() {
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, u_grid_size))) return;
    vec3 q = u_bounce_grid_lo + (vec3(c) + 0.5) / (vec3(u_grid_size) * u_bounce_grid_inv);
    // a centre less than a cell behind the skin of its column (inside the head, where the gather
    // is 0) takes the skin's value, so that the hair in the cell above the skin is not dimmed
    // by interpolating toward the head's inside
    vec4 f = textureLod(u_rsm_flux, q.xy, 0.0);
    if (f.a > 0.5) {
        float zs = textureLod(u_rsm_geom, q.xy, 0.0).w / f.a;
        if (q.z > zs && q.z < zs + 1.0 / (float(u_grid_size.z) * u_bounce_grid_inv.z)) q.z = zs;
    }
    imageStore(u_grid_out, c, vec4(skin_bounce_fluence(rsm_point(q.xy, q.z)), 0.0));
}
