// Collision projection of one particle, for use inside the strand solvers' sweeps
// (strand_solve.comp: DFTL; pbd_length.comp: between iterations). Needs sim_common.glsl and
// collide.glsl first. Two kinds of collider, in this order:
//  - the projection-mode primitives of the colliders buffer (collide.glsl), each in turn:
//    a particle inside moves to its surface point, then Coulomb-style friction removes the
//    tangential part t of its displacement relative to the collider over the step: all of
//    it when |t| <= mu * depth, else mu * depth of it (as collide.comp);
//    PRIMS (a define) is the number of colliders in the buffer, 0 for none in projection
//    mode: a first test of all of them, unrolled and side by side, finds the particles
//    that touch none (most), which skip the sequential projections;
//  - NSDF (0..4, a define) mesh signed distance fields (sdf.py's MeshSDF), each in turn:
//    in the mesh's frame, sdf < margin moves out by margin - sdf along the normalised
//    central-difference gradient, friction as above relative to the mesh, then up to two
//    more projections (as sdf_collide.comp).
#ifndef NSDF
#define NSDF 0
#endif
#ifndef PRIMS
#define PRIMS 0
#endif

#if NSDF > 0
uniform sampler3D sdf_tex[NSDF];
uniform vec4 sdf_lo_h[NSDF];                // mesh frame: xyz first node, w node spacing h
uniform vec4 sdf_params[NSDF];              // x margin, y friction
uniform mat4 sdf_world_to_local[NSDF];
uniform mat4 sdf_local_to_world[NSDF];
uniform mat4 sdf_prev_world_to_local[NSDF];  // the mesh's frame at the previous step

#include "sdf_trilinear.glsl"

// Trilinear texelFetch sample of a texture of the array.
float sdf_at(sampler3D tex, vec3 lo, float h, vec3 x) {
    return sdf_trilinear(tex, lo, h, textureSize(tex, 0), x);
}

vec3 sdf_grad(sampler3D tex, vec3 lo, float h, vec3 x) {   // normalised central difference, e = h / 2
    vec3 g = sdf_trilinear_diff(tex, lo, h, textureSize(tex, 0), x);
    float len = length(g);
    return len > 1e-12 ? g / len : vec3(0.0);
}

// Distance from x to the SDF's box (local frame); the field is >= it there (the box is
// padded around the mesh), so a particle farther than the margin needs no samples.
float sdf_box_distance(sampler3D tex, vec3 lo, float h, vec3 x) {
    vec3 hi = lo + h * vec3(textureSize(tex, 0) - 1);
    return length(x - clamp(x, lo, hi));
}
#endif

#if PRIMS
// CULL: the strand kernels narrow the primitives a strand's sweep tests to those it can reach:
// every particle the sweep places is within the strand's rest arc length of its root (DFTL keeps
// each segment at its rest length), so a primitive farther than that from the root cannot hold
// one, and prims_touch need not test it (bit ci of prims_mask, for the first 32 primitives).
#define CULL (PRIMS <= 32)
uint prims_mask = 0xffffffffu;

// The projection-mode primitives within reach (metres) of root: bit ci set (all of them for a
// non-finite root).
uint prims_reachable(vec3 root, float reach) {
    uint mask = 0u;
    for (int ci = 0; ci < PRIMS && ci < 32; ++ci) {
        Collider c = colliders[ci];
        vec3 pl = transform_point(c.world_to_local, root);
        vec3 radii = c.size.xyz + vec3(c.size.w);
        float dist;
        if (int(c.shape.x) == 1) {   // ellipsoid: inside the sphere of its largest radius
            dist = length(pl) - max(radii.x, max(radii.y, radii.z));
        } else {
            vec3 q = vec3(0.0, int(c.shape.x) == 2 ? clamp(pl.y, -c.shape.z, c.shape.z) : 0.0, 0.0);
            dist = length(pl - q) - radii.x;
        }
        if (!(dist > reach) && int(c.shape.y) == 0) mask |= 1u << uint(ci);
    }
    return mask;
}

// Whether p is inside any projection-mode primitive (never false when collider_depth > 0).
bool prims_touch(vec3 p) {
    bool any_in = false;
#if CULL
    if (prims_mask == 0u) return false;
#endif
    for (int ci = 0; ci < PRIMS; ++ci) {
#if CULL
        if ((prims_mask & (1u << uint(ci))) == 0u) continue;
#endif
        Collider c = colliders[ci];
        vec3 pl = transform_point(c.world_to_local, p);
        vec3 radii = c.size.xyz + vec3(c.size.w);
        bool inside;
        if (int(c.shape.x) == 1) {
            vec3 u = pl / radii;
            inside = dot(u, u) < 1.0;
        } else {
            vec3 q = vec3(0.0, int(c.shape.x) == 2 ? clamp(pl.y, -c.shape.z, c.shape.z) : 0.0, 0.0);
            inside = length(pl - q) < radii.x;
        }
        any_in = any_in || (inside && int(c.shape.y) == 0);
    }
    return any_in;
}
#endif

// Project world point p (free particle, start-of-step position x0) out of every collider.
// True when it moved; normal is then the outward unit normal (world) of the last contact.
bool project_out(inout vec3 p, vec3 x0, out vec3 normal) {
    normal = vec3(0.0);
    bool moved = false;
#if PRIMS
    if (prims_touch(p)) for (int ci = 0; ci < PRIMS; ++ci) {
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
        normal = nw;
        moved = true;
    }
#endif
#if NSDF > 0
    for (int m = 0; m < NSDF; ++m) {
        vec3 lo = sdf_lo_h[m].xyz;
        float h = sdf_lo_h[m].w;
        float margin = sdf_params[m].x;
        vec3 x = transform_point(sdf_world_to_local[m], p);
        if (sdf_box_distance(sdf_tex[m], lo, h, x) > margin) continue;
        float d = sdf_at(sdf_tex[m], lo, h, x);
        if (!(d < margin)) continue;
        vec3 n = sdf_grad(sdf_tex[m], lo, h, x);
        float depth = margin - d;
        x += depth * n;
        vec3 xp = transform_point(sdf_prev_world_to_local[m], x0);
        vec3 disp = x - xp;
        vec3 t = disp - dot(disp, n) * n;
        float slip = length(t);
        if (slip > 0.0) x -= min(sdf_params[m].y * depth / slip, 1.0) * t;
        for (int k = 0; k < 2; ++k) {
            d = sdf_at(sdf_tex[m], lo, h, x);
            if (!(d < margin)) break;
            x += (margin - d) * sdf_grad(sdf_tex[m], lo, h, x);
        }
        p = transform_point(sdf_local_to_world[m], x);
        vec3 nw = mat3(sdf_local_to_world[m]) * n;
        float ln = length(nw);
        normal = ln > 0.0 ? nw / ln : normal;
        moved = true;
    }
#endif
    return moved;
}
