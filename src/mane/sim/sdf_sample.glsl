// Trilinear sample of a MeshSDF's R32F 3D texture (texelFetch, so the same on every GPU).
// Node (i, j, k) sits at sdf_lo + (i, j, k) * sdf_h in the mesh's local frame; outside the
// box the value at the clamped point plus the distance to the box is returned.
uniform sampler3D sdf_texture;
uniform vec3 sdf_lo;
uniform float sdf_h;
uniform ivec3 sdf_res;

#include "sdf_trilinear.glsl"

float sdf_value(vec3 x) {
    return sdf_trilinear(sdf_texture, sdf_lo, sdf_h, sdf_res, x);
}
