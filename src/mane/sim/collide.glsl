// Primitive colliders (layout: mane/sim/colliders.py). Depths are > 0 inside.
struct Collider {
    mat4 world_to_local;
    mat4 prev_local_to_world;
    vec4 shape;     // x type (0 sphere, 1 ellipsoid, 2 capsule), y mode (0 projection, 1 penalty), z capsule half-height
    vec4 size;      // xyz radii, w margin
    vec4 response;  // x friction, y penalty stiffness (1/s^2)
};
layout(std430, binding = B_COLLIDERS) readonly buffer Colliders { Collider colliders[]; };
uniform uint num_colliders;

// Penetration depth of the local point p, the local outward normal n and the local
// surface point s that p projects to.
float collider_depth(Collider c, vec3 p, out vec3 n, out vec3 s) {
    int type = int(c.shape.x);
    vec3 radii = c.size.xyz + vec3(c.size.w);
    if (type == 1) {  // ellipsoid: radial projection
        vec3 u = p / radii;
        float lu = length(u);
        vec3 dir = lu > 1e-12 ? u / lu : vec3(0.0, 1.0, 0.0);
        s = radii * dir;
        n = normalize(s / (radii * radii));
        float d = length(s - p);
        return lu < 1.0 ? d : -d;
    }
    vec3 q = vec3(0.0);
    if (type == 2) q.y = clamp(p.y, -c.shape.z, c.shape.z);
    vec3 d = p - q;
    float dist = length(d);
    n = dist > 1e-12 ? d / dist : vec3(0.0, 1.0, 0.0);
    s = q + n * radii.x;
    return radii.x - dist;
}

// Sum of the penalty springs' accelerations at world point x (penalty-mode colliders).
vec3 penalty_acceleration(vec3 x) {
    vec3 a = vec3(0.0);
    for (uint ci = 0u; ci < num_colliders; ++ci) {
        Collider c = colliders[ci];
        if (int(c.shape.y) != 1) continue;
        vec3 n, s;
        float depth = collider_depth(c, transform_point(c.world_to_local, x), n, s);
        if (depth > 0.0) a += c.response.y * depth * (transpose(mat3(c.world_to_local)) * n);
    }
    return a;
}
