#version 430 core
// MeshSDF collision: in the mesh's frame, particles with sdf < margin go out along the
// normalised central-difference gradient; Coulomb-style friction removes up to friction * depth
// of the tangential motion relative to the mesh since the previous step; two more projections fix what is left inside.
layout(local_size_x = 128) in;

layout(std430, binding = B_POSITIONS) buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PREV_POSITIONS) readonly buffer PrevPositions { vec4 prev_positions[]; };
#include "sdf_sample.glsl"

uniform uint num_particles;
uniform mat4 world_to_local;
uniform mat4 local_to_world;
uniform mat4 prev_world_to_local;
uniform float margin;
uniform float friction;

vec3 sdf_normal(vec3 x) {   // normalised central difference, e = h / 2
    vec3 g = sdf_trilinear_diff(sdf_texture, sdf_lo, sdf_h, sdf_res, x);
    float len = length(g);
    return len > 1e-12 ? g / len : vec3(0.0);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_particles) return;
    vec4 p = positions[i];
    if (p.w == 0.0) return;
    vec3 x = (world_to_local * vec4(p.xyz, 1.0)).xyz;
    float d = sdf_value(x);
    if (!(d < margin)) return;
    vec3 n = sdf_normal(x);
    float depth = margin - d;
    x += depth * n;
    // Coulomb-style: remove min(|t|, friction * depth) of the tangential motion t
    vec3 xp = (prev_world_to_local * vec4(prev_positions[i].xyz, 1.0)).xyz;
    vec3 disp = x - xp;
    vec3 t = disp - dot(disp, n) * n;
    float slip = length(t);
    if (slip > 0.0) x -= min(friction * depth / slip, 1.0) * t;
    for (int k = 0; k < 2; ++k) {
        d = sdf_value(x);
        if (!(d < margin)) break;
        x += (margin - d) * sdf_normal(x);
    }
    positions[i] = vec4((local_to_world * vec4(x, 1.0)).xyz, p.w);
}
