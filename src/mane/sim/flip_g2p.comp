#version 430 core
// FLIP grid -> particle (Chen eq. 5): v = alpha (v_p + Lerp(u - u*)) + (1 - alpha) Lerp(u).
// Pinned particles (w = 0) keep their velocity.
layout(local_size_x = 128) in;

layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) buffer Velocities { vec4 velocities[]; };
#include "flip_grid.glsl"
layout(std430, binding = B_FACES) readonly buffer Faces { vec2 faces[]; };

uniform uint num_particles;
uniform float flip_ratio;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_particles) return;
    vec4 p = positions[i];
    if (p.w == 0.0 || any(isnan(p.xyz)) || any(isinf(p.xyz))) return;
    float h = grid_h();
    vec3 g = (p.xyz - grid_origin(h)) / h;
    vec3 pic = vec3(0.0), delta = vec3(0.0);
    for (int a = 0; a < 3; ++a) {
        FaceStencil s = face_stencil(a, g);
        for (int c = 0; c < 8; ++c) {
            ivec3 o = corner_offset(c);
            float w = corner_weight(s.frac, o);
            vec2 uf = faces[face_index(a, s.base + o)];
            pic[a] += w * uf.x;
            delta[a] += w * (uf.x - uf.y);
        }
    }
    vec4 v = velocities[i];
    velocities[i] = vec4(flip_ratio * (v.xyz + delta) + (1.0 - flip_ratio) * pic, v.w);
}
