#version 430 core
// Projection-mode colliders (one thread per particle), each in turn: a particle inside
// moves to its surface point; then Coulomb-style friction removes the tangential part t
// of its displacement relative to the collider over the step: all of it when
// |t| <= mu * depth, else mu * depth of it.
#include "sim_common.glsl"
#include "collide.glsl"

layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_strands * uint(NV)) return;
    if (rest_positions[i].w == 0.0) return;
    vec3 p = positions[i].xyz;
    vec3 x0 = prev_positions[i].xyz;
    bool moved = false;
    for (uint ci = 0u; ci < num_colliders; ++ci) {
        Collider c = colliders[ci];
        if (int(c.shape.y) != 0) continue;
        vec3 pl = transform_point(c.world_to_local, p);
        vec3 n, sl;
        float depth = collider_depth(c, pl, n, sl);
        if (!(depth > 0.0)) continue;
        mat3 to_world = transpose(mat3(c.world_to_local));
        vec3 nw = normalize(to_world * n);
        p += to_world * (sl - pl);
        float mu = c.response.x;
        if (mu > 0.0) {
            vec3 rel = transform_point(c.prev_local_to_world, sl) - x0;
            vec3 t = rel - dot(rel, nw) * nw;
            float lt = length(t);
            float lim = mu * depth;
            p -= lt <= lim ? t : t * (lim / lt);
        }
        moved = true;
    }
    if (moved) positions[i].xyz = p;
}
