#version 430 core
// Shape constraints, one thread per strand, `iterations` Gauss-Seidel sweeps, each
// with per-iteration stiffness (1 - (1 - k)^(1/n), converted on the CPU):
//  local shape (after TressFX): a frame F starts as head * root bind frame and is carried
//    root to tip. Segment k -> k+1 is turned about p_k by the fraction k_it of its angle
//    to F * ref_{k+1} (its bind-pose vector in that frame) and its length moves the same
//    fraction toward the rest length; the rest of the strand moves rigidly with it (an angular spring at every joint: fixing one joint leaves the angles
//    further down alone, so n sweeps of k_it remove exactly 1 - (1 - k_it)^n = k of every
//    joint's error, independent of n). F then follows the segment by the smallest
//    rotation taking its x axis onto it. Stiffness 1 rebuilds the bind pose in one sweep.
//  bending: a joint bent beyond its rest angle (between segments k-1 and k) is unbent
//    the fraction k_it of the excess, turning segment k (and, rigidly, the strand below
//    it) about p_k in the plane of the two segments. No preferred direction: straight
//    hair stays straight, kinks are limited; a joint straighter than at rest is left
//    alone (curls are local shape's job). Same per-iteration argument.
#include "sim_common.glsl"

layout(local_size_x = 64) in;

uniform mat4 head;
uniform float local_stiffness;    // per iteration
uniform float bending_stiffness;  // per iteration
uniform int iterations;

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

// Rotation by angle (radians) about the unit axis (Rodrigues).
mat3 axis_rotation(vec3 axis, float angle) {
    float c = cos(angle), s = sin(angle);
    mat3 K = mat3(vec3(0.0, axis.z, -axis.y), vec3(-axis.z, 0.0, axis.x), vec3(axis.y, -axis.x, 0.0));
    return mat3(1.0) + s * K + (1.0 - c) * (K * K);
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

void main() {
    uint s = gl_GlobalInvocationID.x;
    if (s >= num_strands) return;
    uint base = s * uint(NV);
    vec3 p[NV];
    float w[NV];
    vec3 origin = positions[base].xyz;  // work relative to the root: smaller numbers, less round-off
    for (uint k = 0u; k < uint(NV); ++k) {
        p[k] = positions[base + k].xyz - origin;
        w[k] = rest_positions[base + k].w;
    }
    mat3 H = mat3(head);
    mat3 R0 = mat3(root_frames[3u * s].xyz, root_frames[3u * s + 1u].xyz, root_frames[3u * s + 2u].xyz);
    for (int it = 0; it < iterations; ++it) {
        if (local_stiffness > 0.0) {
            mat3 F = H * R0;
            mat3 Racc = mat3(1.0);  // upstream corrections, applied lazily: x -> Racc x + tacc
            vec3 tacc = vec3(0.0);
            for (uint k = 0u; k + 1u < uint(NV); ++k) {
                vec3 q = p[k + 1u];
                if (w[k + 1u] > 0.0) {
                    q = Racc * q + tacc;
                    vec3 a = q - p[k];
                    vec3 b = F * shape_refs[base + k + 1u].xyz;
                    mat3 R = rotate_toward(a, b, local_stiffness);
                    vec3 ra = R * a;
                    float la = length(a);
                    vec3 stretch = la > 1e-12 ? ra * (local_stiffness * (length(b) / la - 1.0)) : vec3(0.0);
                    q = p[k] + ra + stretch;
                    Racc = R * Racc;
                    tacc = R * (tacc - p[k]) + p[k] + stretch;
                } else {
                    Racc = mat3(1.0);  // a pinned particle carries nothing past it
                    tacc = vec3(0.0);
                }
                p[k + 1u] = q;
                vec3 d = p[k + 1u] - p[k];
                float len = length(d);
                if (rest_info[base + k + 1u].x > 1e-12 && len > 1e-12) {
                    vec3 u = normalize(transpose(F) * (d / len));
                    F = F * min_rotation_from_x(u);
                }
            }
        }
        if (bending_stiffness > 0.0) {
            mat3 Racc = mat3(1.0);
            vec3 tacc = vec3(0.0);
            for (uint k = 1u; k + 1u < uint(NV); ++k) {
                vec3 q = p[k + 1u];
                if (w[k + 1u] > 0.0) {
                    q = Racc * q + tacc;
                    vec3 e0 = p[k] - p[k - 1u];
                    vec3 a = q - p[k];
                    vec3 n = cross(e0, a);
                    float sn = length(n);
                    float l0 = length(e0), la = length(a);
                    if (l0 > 1e-12 && la > 1e-12 && sn > 1e-9 * l0 * la) {
                        float angle = angle_of(sn, dot(e0, a));
                        float rest_angle = rest_info[base + k + 1u].z;
                        float err = angle - rest_angle;
                        // unilateral: joints bent beyond their rest angle are unbent; joints
                        // straighter than at rest are left alone (bending them back toward a
                        // curl pumps energy into the strand; curls are local shape's job)
                        if (err < 0.0) err = 0.0;
                        mat3 R = axis_rotation(n / sn, -bending_stiffness * err);
                        q = p[k] + R * a;
                        Racc = R * Racc;
                        tacc = R * (tacc - p[k]) + p[k];
                    }
                } else {
                    Racc = mat3(1.0);
                    tacc = vec3(0.0);
                }
                p[k + 1u] = q;
            }
        }
    }
    for (uint k = 1u; k < uint(NV); ++k) positions[base + k].xyz = p[k] + origin;
}
