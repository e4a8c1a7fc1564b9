// Buffers and helpers shared by the strand solver's kernels (layout: mane/sim/state.py).
// NV (points per strand) is injected as a define by the simulator.
#ifndef NV
#error "NV (points per strand) must be defined"
#endif

layout(std430, binding = B_POSITIONS) buffer Positions { vec4 positions[]; };          // xyz m, w inverse mass
layout(std430, binding = B_PREV_POSITIONS) buffer PrevPositions { vec4 prev_positions[]; };  // start of the step
layout(std430, binding = B_VELOCITIES) buffer Velocities { vec4 velocities[]; };        // xyz m/s
layout(std430, binding = B_REST_POSITIONS) readonly buffer RestPositions { vec4 rest_positions[]; };  // head frame, w inverse mass
layout(std430, binding = B_REST_INFO) readonly buffer RestInfo { vec4 rest_info[]; };  // seg length, arc, bend angle, base length
layout(std430, binding = B_CORRECTIONS) buffer Corrections { vec4 corrections[]; };      // DFTL d_k
layout(std430, binding = B_SHAPE_REFS) readonly buffer ShapeRefs { vec4 shape_refs[]; };
layout(std430, binding = B_ROOT_FRAMES) readonly buffer RootFrames { vec4 root_frames[]; };
layout(std430, binding = B_GUARD) buffer Guard { uint guard[]; };

uniform uint num_strands;

// Exponent bits all ones = inf or NaN; immune to fast-math folding of isnan().
bool finite1(float x) { return (floatBitsToUint(x) & 0x7f800000u) != 0x7f800000u; }
bool finite3(vec3 v) {
    uvec3 e = floatBitsToUint(v) & uvec3(0x7f800000u);
    return all(notEqual(e, uvec3(0x7f800000u)));
}

vec3 transform_point(mat4 m, vec3 p) { return (m * vec4(p, 1.0)).xyz; }

// The smallest rotation taking e_x to the unit vector u (Rodrigues, c = cos angle).
mat3 min_rotation_from_x(vec3 u) {
    float c = u.x;
    if (c < -1.0 + 1e-6) return mat3(vec3(-1.0, 0.0, 0.0), vec3(0.0, -1.0, 0.0), vec3(0.0, 0.0, 1.0));
    vec3 v = vec3(0.0, -u.z, u.y);  // e_x x u
    mat3 K = mat3(vec3(0.0, v.z, -v.y), vec3(-v.z, 0.0, v.x), vec3(v.y, -v.x, 0.0));  // columns
    return c * mat3(1.0) + K + outerProduct(v, v) / (1.0 + c);
}
