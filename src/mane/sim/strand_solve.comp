#version 430 core
// The per-strand solver: one thread per strand streams its strand root to tip, keeping only
// the last vertices and each sweep's carried state in registers (no per-thread arrays, which
// NVIDIA puts in local memory when indexed dynamically), as a pipeline of stages that each
// vertex goes through in turn. Compile-time switches (the simulator picks them):
//
//  SHAPE (0/1): `iterations` Gauss-Seidel sweeps of local shape then bending, each with the
//    per-iteration stiffness (1 - (1 - k)^(1/n), converted on the CPU):
//    local shape (after TressFX): a frame F starts as head * root bind frame and is carried
//      root to tip. Segment k -> k+1 is turned about p_k by the fraction k_it of its angle to
//      F * ref_{k+1} (its bind-pose vector in that frame) and its length moves the same
//      fraction toward the rest length; the rest of the strand moves rigidly with it (an
//      angular spring at every joint: fixing one joint leaves the angles further down alone,
//      so n sweeps of k_it remove exactly 1 - (1 - k_it)^n = k of every joint's error,
//      independent of n). F then follows the segment by the smallest rotation taking its x
//      axis onto it. Stiffness 1 rebuilds the bind pose in one sweep.
//    bending: a joint bent beyond its rest angle (between segments k-1 and k) is unbent the
//      fraction k_it of the excess, turning segment k (and, rigidly, the strand below it)
//      about p_k in the plane of the two segments. No preferred direction: straight hair
//      stays straight, kinks are limited; a joint straighter than at rest is left alone
//      (curls are local shape's job). Same per-iteration argument.
//    A sweep's correction of the strand below a joint is carried lazily (x -> R x + t) and
//    applied as the sweep reaches each vertex, so sweep i+1 can follow sweep i one vertex
//    behind: STAGES sweeps run pipelined in one pass over the strand; with more iterations
//    than STAGES, the earlier ones take extra passes (through memory). The results are
//    those of the sweeps one after the other.
//  DFTL (0/1): Dynamic Follow-The-Leader (Müller, Kim, Chentanez 2012) with the collisions
//    inside the sweep, root to tip, pinned particles staying and leading:
//      p_k = p_{k-1} + l_k * normalize(x_k - p_{k-1})      (x_k: the predicted position)
//      then, CONTACT_ITERATIONS times while p_k is inside a collider (contact.glsl):
//        q = p_k projected out (with friction), n the contact normal;
//        p_k = the point at distance l_k from p_{k-1} nearest q on the plane through q
//              normal to n (back_to_length)
//    so the segment keeps its length exactly and, the plane being outside a convex
//    collider, ends outside it (a leader deep inside can make both impossible: the length
//    wins). d_k = p_k - x_k less the collision pushes is kept for the velocity correction.
//    A segment of zero length takes the direction of its rest segment under the head.
//  PRIMS (colliders in the buffer, 0 for no projection-mode one), NSDF (0..4): the
//    colliders of the sweep (primitives of the colliders buffer in projection mode; mesh SDFs).
//  VELOCITY (0/1): v = (x - x_prev) / dt, plus DFTL's correction v_k += -s d_{k+1} / dt for
//    free particles below the tip, |v| <= max_speed (velocity.comp's update, done as soon
//    as d_{k+1} is known).
//  BOUNDS (0/1): GridBounds' reduction (bounds.comp, STAGE_REDUCE) of the positions the
//    kernel leaves, for the grid friction pass that follows: a min/max per invocation over its
//    strand, then per work group in shared memory (LOCAL_SIZE a power of 2), then 6 global
//    atomics per group on the box's keys at BOUNDS_BINDING. Non-finite positions are skipped.
//  CORRECTIONS (0/1): d_k goes to the corrections buffer (velocity.comp's input); the fused
//    kernel (VELOCITY) uses it in registers and skips the writes unless asked for them.
//  INTEGRATE (0/1/2): integrate.comp's work (forces, prediction, pinned follicles on the
//    head, global shape; prev_positions takes x where finite) done as the kernel first reads
//    each vertex: 1 in the last pass over the strand, 2 in the first of the shape pre-passes
//    (the simulator picks 2 when there are pre-passes). Saves integrate's own pass over the
//    positions, velocities and rest positions. PENALTY (0/1): penalty-mode colliders exist.
//  CULL_PRIMS (0/1, default 1): every particle the sweep places lies within the strand's rest
//    arc length of its root, so the primitives farther than that from the root are left out of
//    the strand's tests (contact.glsl's prims_mask); the same results, fewer tests.
//  GUARD (0/1): nan_guard.comp's tests and recovery in the kernel (with DFTL and VELOCITY):
//    the strand fails when a position or velocity it leaves is not finite, a speed exceeds
//    max_speed_abs or a particle lies farther from the root than max_stretch * rest arc + 1 cm;
//    a failed strand goes back to its start-of-step positions (prev_positions, when they pass
//    the same position tests; else the rest pose under the head) with zero velocity, and is
//    counted in guard[0] (guard[1]: the largest recovered strand + 1). Saves the guard's pass.
#include "sim_common.glsl"
#include "collide.glsl"
#include "contact.glsl"

#ifndef SHAPE
#define SHAPE 0
#endif
#ifndef DFTL
#define DFTL 0
#endif
#ifndef VELOCITY
#define VELOCITY 0
#endif
#ifndef STAGES
#define STAGES 1
#endif
#define CONTACT (PRIMS > 0 || NSDF > 0)
#define CONTACT_ITERATIONS 2
#ifndef LOCAL_SIZE
#define LOCAL_SIZE 64
#endif
#ifndef INTEGRATE
#define INTEGRATE 0
#endif
#ifndef CORRECTIONS
#define CORRECTIONS 1
#endif
#ifndef BOUNDS
#define BOUNDS 0
#endif
#ifndef PENALTY
#define PENALTY 1
#endif
#ifndef CULL_PRIMS
#define CULL_PRIMS 1
#endif
#ifndef GUARD
#define GUARD 0
#endif
#if GUARD && !(DFTL && VELOCITY)
#error "GUARD needs DFTL and VELOCITY"
#endif

layout(local_size_x = LOCAL_SIZE) in;

uniform mat4 head;
uniform float local_stiffness;    // per iteration
uniform float bending_stiffness;  // per iteration
uniform int iterations;
uniform float dt;
uniform float dftl_damping;
uniform float max_speed;
#if GUARD
uniform float max_stretch;
uniform float max_speed_abs;
#endif

#if BOUNDS
#include "grid_bounds.glsl"
shared vec3 s_lo[LOCAL_SIZE];
shared vec3 s_hi[LOCAL_SIZE];
vec3 b_lo = vec3(uintBitsToFloat(0x7f800000u));   // +inf: no finite position yet
vec3 b_hi = vec3(uintBitsToFloat(0xff800000u));
int float_key(float f) {  // bounds.comp's order-preserving key
    int b = floatBitsToInt(f);
    return b >= 0 ? b : b ^ 0x7fffffff;
}
#endif
void bounds_forget() {  // drop what this invocation has reduced (its strand is recovered)
#if BOUNDS
    b_lo = vec3(uintBitsToFloat(0x7f800000u));
    b_hi = vec3(uintBitsToFloat(0xff800000u));
#endif
}
void bounds_add(vec3 p) {
#if BOUNDS
    if (finite3(p)) {
        b_lo = min(b_lo, p);
        b_hi = max(b_hi, p);
    }
#endif
}

#if INTEGRATE
#include "wind.glsl"
uniform vec3 gravity;            // m/s^2
uniform float damping_factor;    // exp(-damping * dt)
uniform float drag;              // 1/s
uniform float global_stiffness;  // [0, 1]
uniform float global_range;      // [0, 1]
uniform float time;              // s, start of the step
uniform int wind_on;

// integrate.comp for particle i (k-th of its strand, start position x, wind w of its strand):
// prev_positions[i] takes x where finite (x0 = x; else x0 = the last valid one it keeps);
// returns the predicted position.
vec3 integrate_vertex(uint k, uint i, vec3 x, vec4 rest, vec3 w, out vec3 x0) {
    if (finite3(x)) {
        prev_positions[i] = vec4(x, rest.w);
        x0 = x;
    } else {
        x0 = prev_positions[i].xyz;
    }
    vec3 target = transform_point(head, rest.xyz);
    if (rest.w == 0.0) return target;
    vec3 v = velocities[i].xyz;
    vec3 a = gravity;
    if (drag > 0.0) a += drag * (w - v);
#if PENALTY
    a += penalty_acceleration(x);
#endif
    v = v * damping_factor + dt * a;
    float speed = length(v);
    if (speed > max_speed) v *= max_speed / speed;
    vec3 p = x + dt * v;
    if (global_stiffness > 0.0 && float(k) <= global_range * float(NV - 1) + 1e-4)
        p += global_stiffness * (target - p);
    return p;
}
#endif

#if SHAPE
// atan(y / x) for y >= 0 to float precision (Cephes atanf; Mesa's atan is ~3e-6 off).
float atan_positive(float t) {
    float y0 = 0.0;
    if (t > 2.414213562373095) {
        y0 = 1.5707963267948966;
        t = -1.0 / t;
    } else if (t > 0.4142135623730950) {
        y0 = 0.7853981633974483;
        t = (t - 1.0) / (t + 1.0);
    }
    float z = t * t;
    return y0 + ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
                  - 3.33329491539e-1) * z * t + t);
}

float angle_of(float sn, float cs) {  // atan2(sn, cs) for sn >= 0
    if (cs > 0.0) return atan_positive(sn / cs);
    if (cs < 0.0) return 3.141592653589793 - atan_positive(sn / -cs);
    return 1.5707963267948966;
}

// Rotation by angle (radians) about the unit axis (Rodrigues), written as c I + s K + (1 - c) n n^T
// (K^2 = n n^T - I for a unit axis n), column by column: fewer operations than forming K^2.
mat3 axis_rotation(vec3 axis, float angle) {
    float c = cos(angle), s = sin(angle);
    vec3 tn = (1.0 - c) * axis, sn = s * axis;
    return mat3(tn.x * axis + vec3(c, sn.z, -sn.y),
                tn.y * axis + vec3(-sn.z, c, sn.x),
                tn.z * axis + vec3(sn.y, -sn.x, c));
}

// Rotation by the fraction f of the angle from a to b, about a x b.
mat3 rotate_toward(vec3 a, vec3 b, float f) {
    float la = length(a), lb = length(b);
    if (!(la > 1e-12) || !(lb > 1e-12)) return mat3(1.0);
    a /= la;
    b /= lb;
    vec3 axis = cross(a, b);
    float sn = length(axis);
    float cs = dot(a, b);
    if (sn < 1e-9) {
        if (cs > 0.0) return mat3(1.0);
        axis = abs(a.x) < 0.9 ? cross(a, vec3(1.0, 0.0, 0.0)) : cross(a, vec3(0.0, 1.0, 0.0));
        sn = length(axis);
    }
    return axis_rotation(axis / sn, f * angle_of(length(cross(a, b)), cs));
}

// One iteration's sweeps (local shape, then bending) as they pass down a strand; positions
// relative to the root.
struct Sweep {
    mat3 F;             // local shape: the bind frame carried to the current segment
    mat3 Rl;            // local shape's correction of the strand below: x -> Rl x + tl
    vec3 tl;
    mat3 Rb;            // bending's
    vec3 tb;
    vec3 l1;            // local shape's result at the previous vertex
    vec3 b1;            // bending's result at the previous vertex
    vec3 b0;            // ... and the one before
};

Sweep sweep_start(mat3 F0) {
    return Sweep(F0, mat3(1.0), vec3(0.0), mat3(1.0), vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0));
}

// Vertex k + 1 (position q) through the sweep; returns its new position.
vec3 sweep_vertex(inout Sweep S, uint k, vec3 q, bool free_, float seg_rest, vec3 ref, float rest_angle) {
    if (local_stiffness > 0.0) {
        vec3 pk = S.l1;
        if (free_) {
            q = S.Rl * q + S.tl;
            vec3 a = q - pk;
            vec3 b = S.F * ref;
            mat3 R = rotate_toward(a, b, local_stiffness);
            vec3 ra = R * a;
            float la = length(a);
            vec3 stretch = la > 1e-12 ? ra * (local_stiffness * (length(b) / la - 1.0)) : vec3(0.0);
            q = pk + ra + stretch;
            S.Rl = R * S.Rl;
            S.tl = R * (S.tl - pk) + pk + stretch;
        } else {
            S.Rl = mat3(1.0);  // a pinned particle carries nothing past it
            S.tl = vec3(0.0);
        }
        vec3 d = q - pk;
        float len = length(d);
        if (seg_rest > 1e-12 && len > 1e-12) {
            vec3 u = normalize(transpose(S.F) * (d / len));
            S.F = S.F * min_rotation_from_x(u);
        }
        S.l1 = q;
    }
    if (bending_stiffness > 0.0) {
        if (k >= 1u) {
            if (free_) {
                q = S.Rb * q + S.tb;
                vec3 e0 = S.b1 - S.b0;
                vec3 a = q - S.b1;
                vec3 n = cross(e0, a);
                float sn = length(n);
                float l0 = length(e0), la = length(a);
                if (l0 > 1e-12 && la > 1e-12 && sn > 1e-9 * l0 * la) {
                    float err = angle_of(sn, dot(e0, a)) - rest_angle;
                    // unilateral: joints bent beyond their rest angle are unbent; joints
                    // straighter than at rest are left alone (bending them back toward a
                    // curl pumps energy into the strand; curls are local shape's job)
                    if (err < 0.0) err = 0.0;
                    mat3 R = axis_rotation(n / sn, -bending_stiffness * err);
                    q = S.b1 + R * a;
                    S.Rb = R * S.Rb;
                    S.tb = R * (S.tb - S.b1) + S.b1;
                }
            } else {
                S.Rb = mat3(1.0);
                S.tb = vec3(0.0);
            }
        }
        S.b0 = S.b1;
        S.b1 = q;
    }
    return q;
}

// Vertex k + 1 through `count` (1..STAGES) pipelined sweeps.
vec3 sweep_stages(inout Sweep S0, inout Sweep S1, inout Sweep S2, inout Sweep S3, int count,
                  uint k, vec3 q, bool free_, vec4 info, vec3 ref) {
    q = sweep_vertex(S0, k, q, free_, info.x, ref, info.z);
#if STAGES > 1
    if (count > 1) q = sweep_vertex(S1, k, q, free_, info.x, ref, info.z);
#endif
#if STAGES > 2
    if (count > 2) q = sweep_vertex(S2, k, q, free_, info.x, ref, info.z);
#endif
#if STAGES > 3
    if (count > 3) q = sweep_vertex(S3, k, q, free_, info.x, ref, info.z);
#endif
    return q;
}
#endif

// The primitives the strand rooted at origin (first particle base) can reach (contact.glsl's CULL).
void cull_prims(vec3 origin, uint base) {
#if DFTL && PRIMS && CULL && CULL_PRIMS
    prims_mask = prims_reachable(origin, rest_info[base + uint(NV) - 1u].y * 1.001 + 1e-4);
#endif
}

#if DFTL && CONTACT
// Particle k back at distance l from its leader a after a collision moved it from p to q
// (outward normal n there): the point at distance l from a nearest q on the plane through
// q normal to n (for a convex collider that plane is outside it, so the particle ends both
// at its length and outside), or, when the sphere of radius l about a does not reach the
// plane, the point at distance l from a toward q.
vec3 back_to_length(vec3 a, float l, vec3 p, vec3 q, vec3 n) {
    float ha = dot(a - q, n);  // height of the leader over the plane
    vec3 f = q - a;
    if (abs(ha) < l) {
        vec3 c = a - ha * n;   // centre of the circle where the sphere meets the plane
        vec3 u = q - c;
        float lu = length(u);
        if (!(lu > 1e-6 * l)) {  // q right under its leader: along p's side instead
            u = p - c;
            u -= dot(u, n) * n;
            lu = length(u);
        }
        if (lu > 1e-12) return c + sqrt(l * l - ha * ha) * (u / lu);
    }
    float lf = length(f);
    return lf > 1e-12 ? a + l * (f / lf) : q;
}
#endif

#if GUARD
// nan_guard.comp's recovery of strand s (first particle base): back to its start-of-step
// positions when they are finite and within reach of their root, else to its rest pose under
// the head, with zero velocities.
void recover(uint s, uint base) {
    vec3 root0 = prev_positions[base].xyz;
    bool prev_ok = true;
    for (uint k = 0u; k < uint(NV); ++k) {
        uint i = base + k;
        vec3 xp = prev_positions[i].xyz;
        prev_ok = prev_ok && finite3(xp) && length(xp - root0) <= max_stretch * rest_info[i].y + 0.01;
    }
    bounds_forget();
    for (uint k = 0u; k < uint(NV); ++k) {
        uint i = base + k;
        vec4 rest = rest_positions[i];
        vec3 x = (prev_ok && rest.w > 0.0) ? prev_positions[i].xyz : transform_point(head, rest.xyz);
        positions[i] = vec4(x, rest.w);
        prev_positions[i] = vec4(x, rest.w);
        velocities[i] = vec4(0.0);
        corrections[i] = vec4(0.0);
        bounds_add(x);
    }
    atomicAdd(guard[0], 1u);
    atomicMax(guard[1], s + 1u);
}
#endif

void solve(uint s) {
    uint base = s * uint(NV);
    mat3 H = mat3(head);
#if INTEGRATE
    vec4 rest0 = rest_positions[base];
    vec3 wind = vec3(0.0);
    if (drag > 0.0 && wind_on != 0) wind = wind_at(s, transform_point(head, rest0.xyz), time);
    vec3 start0;  // the root at the start of the step
    vec3 origin = integrate_vertex(0u, base, positions[base].xyz, rest0, wind, start0);
    positions[base] = vec4(origin, rest0.w);
#else
    vec3 origin = positions[base].xyz;  // the shape sweeps work relative to the root (less round-off)
#endif
    bounds_add(origin);
    cull_prims(origin, base);
#if GUARD
    bool ok = finite3(origin);  // the verdict on the strand
#endif
    int count = 1;
#if SHAPE
    mat3 F0 = H * mat3(root_frames[3u * s].xyz, root_frames[3u * s + 1u].xyz, root_frames[3u * s + 2u].xyz);
    Sweep S0 = sweep_start(F0), S1 = S0, S2 = S0, S3 = S0;
    // all but the last STAGES iterations: passes of STAGES pipelined sweeps, through memory
    int done = 0;
    for (; iterations - done > STAGES; done += STAGES) {
        S0 = sweep_start(F0); S1 = S0; S2 = S0; S3 = S0;
        for (uint k = 1u; k < uint(NV); ++k) {
            uint i = base + k;
            vec4 x = positions[i];
#if INTEGRATE == 2
            vec4 rest = rest_positions[i];
            if (done == 0) {
                vec3 start;
                x = vec4(integrate_vertex(k, i, x.xyz, rest, wind, start), rest.w);
            }
            bool free_ = rest.w > 0.0;
#else
            bool free_ = rest_positions[i].w > 0.0;
#endif
            vec3 q = sweep_stages(S0, S1, S2, S3, STAGES, k - 1u, x.xyz - origin, free_,
                                  rest_info[i], shape_refs[i].xyz);
            positions[i] = vec4(q + origin, x.w);
        }
    }
    count = iterations - done;
    S0 = sweep_start(F0); S1 = S0; S2 = S0; S3 = S0;
#endif
#if DFTL
    vec3 prev = origin;                     // p_{k-1}, final
    vec3 rest_prev = rest_positions[base].xyz;
#if CORRECTIONS
    corrections[base] = vec4(0.0);
#endif
#if VELOCITY
    vec3 vx = origin;                       // particle k-1: final position, start of the step,
#if INTEGRATE == 1
    vec3 vx0 = start0;                      // free
#else
    vec3 vx0 = prev_positions[base].xyz;
#endif
    bool vfree = rest_positions[base].w > 0.0;
#endif
#endif
    // the last pass: the remaining sweeps, DFTL, collisions, velocities; each vertex's data is
    // loaded where it is used (prefetching the next one measured slower: docs/performance.md)
    for (uint k = 1u; k < uint(NV); ++k) {
        uint i = base + k;
        vec4 x = positions[i], rest = rest_positions[i], info = rest_info[i];
#if SHAPE
        vec3 ref = shape_refs[i].xyz;
#endif
#if INTEGRATE == 1
        vec3 x0;  // start of the step
        x = vec4(integrate_vertex(k, i, x.xyz, rest, wind, x0), rest.w);
#elif DFTL && (CONTACT || VELOCITY)
        vec3 x0 = prev_positions[i].xyz;
#endif
        bool free_ = rest.w > 0.0;
        vec3 xp = x.xyz;  // predicted position
#if SHAPE
        xp = sweep_stages(S0, S1, S2, S3, count, k - 1u, xp - origin, free_, info, ref) + origin;
#endif
#if DFTL
        vec3 p = xp;
        vec3 d = vec3(0.0);
        if (free_) {
            vec3 e = xp - prev;
            float len = length(e);
            vec3 dir;
            if (!finite3(e)) {
                dir = e;  // let NaN through: the guard resets the strand
            } else if (len > 1e-12) {
                dir = e / len;
            } else {
                vec3 r = H * (rest.xyz - rest_prev);
                dir = length(r) > 1e-12 ? normalize(r) : vec3(0.0, -1.0, 0.0);
            }
            float l = info.x;
            p = prev + l * dir;
            vec3 push = vec3(0.0);
#if CONTACT
            for (int c = 0; c < CONTACT_ITERATIONS; ++c) {
                vec3 q = p, n;
                if (!project_out(q, x0, n)) break;
                push += q - p;
                p = back_to_length(prev, l, p, q, n);
            }
#endif
            d = p - xp - push;
        }
#if CORRECTIONS
        corrections[i] = vec4(d, 0.0);
#endif
        positions[i] = vec4(p, x.w);
        bounds_add(p);
#if GUARD
        ok = ok && finite3(p) && length(p - origin) <= max_stretch * info.y + 0.01;
#endif
#if VELOCITY
        {   // particle k-1, now that d_k is known
            vec3 v = (vx - vx0) / dt;
            if (dftl_damping > 0.0 && vfree) v -= dftl_damping * d / dt;
            float speed = length(v);
            if (speed > max_speed) v *= max_speed / speed;
            velocities[i - 1u] = vec4(v, 0.0);
#if GUARD
            ok = ok && finite3(v) && length(v) <= max_speed_abs;
#endif
            vx = p;
            vx0 = x0;
            vfree = free_;
        }
#endif
        prev = p;
        rest_prev = rest.xyz;
#else
        positions[i] = vec4(xp, x.w);
        bounds_add(xp);
#endif
    }
#if DFTL && VELOCITY
    vec3 v = (vx - vx0) / dt;  // the tip
    float speed = length(v);
    if (speed > max_speed) v *= max_speed / speed;
    velocities[base + uint(NV) - 1u] = vec4(v, 0.0);
#if GUARD
    ok = ok && finite3(v) && length(v) <= max_speed_abs;
    if (!ok) recover(s, base);
#endif
#endif
}

void main() {
    uint s = gl_GlobalInvocationID.x;
    if (s < num_strands) solve(s);
#if BOUNDS
    uint lid = gl_LocalInvocationID.x;
    s_lo[lid] = b_lo;
    s_hi[lid] = b_hi;
    barrier();
    for (uint off = uint(LOCAL_SIZE) / 2u; off > 0u; off >>= 1) {
        if (lid < off) {
            s_lo[lid] = min(s_lo[lid], s_lo[lid + off]);
            s_hi[lid] = max(s_hi[lid], s_hi[lid + off]);
        }
        barrier();
    }
    if (lid == 0u && finite3(s_lo[0])) {
        vec3 lo = s_lo[0], hi = s_hi[0];
        atomicMin(bounds_keys[0], float_key(lo.x)); atomicMin(bounds_keys[1], float_key(lo.y));
        atomicMin(bounds_keys[2], float_key(lo.z));
        atomicMax(bounds_keys[4], float_key(hi.x)); atomicMax(bounds_keys[5], float_key(hi.y));
        atomicMax(bounds_keys[6], float_key(hi.z));
    }
#endif
}
