#version 430 core
// Prediction (one thread per particle):
//   pinned (w = 0):  x = head * rest                   (follicles ride on the head)
//   free:            a = g + drag * (wind - v) + penalty springs
//                    v' = v * exp(-damping dt) + dt a ; |v'| <= max_speed
//                    x' = x + dt v'
//                    x' += global_stiffness * (head * rest - x')   for k / (N-1) <= range
// prev_positions takes x first, but only where x is finite: after NaN it keeps the
// last valid position for the guard.
// GATHER (0/1): first the previous step's grid friction gather, v <- (1 - f) v + f V(x) for
// free particles (grid_gather.comp, with the grid its splat left at GRID_BINDING and the box
// at BOUNDS_BINDING): the simulator defers it here to save a pass over the particles.
#include "sim_common.glsl"
#include "collide.glsl"
#include "wind.glsl"
#ifndef GATHER
#define GATHER 0
#endif
#if GATHER
layout(std430, binding = GRID_BINDING) readonly buffer Grid { vec4 grid[]; };
#include "grid_nodes.glsl"
#include "grid_velocity.glsl"
uniform float friction;
#endif

#ifndef PENALTY
#define PENALTY 1  // penalty-mode colliders exist (the simulator sets 0 when none do)
#endif

layout(local_size_x = 64) in;

uniform mat4 head;               // head frame -> world
uniform float dt;                // s
uniform vec3 gravity;            // m/s^2
uniform float damping_factor;    // exp(-damping * dt)
uniform float drag;              // 1/s
uniform float max_speed;         // m/s
uniform float global_stiffness;  // [0, 1]
uniform float global_range;      // [0, 1]
uniform float time;              // s, start of the step
uniform int wind_on;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= num_strands * uint(NV)) return;
    uint s = i / uint(NV);
    uint k = i - s * uint(NV);
    vec4 rest = rest_positions[i];
    vec3 target = transform_point(head, rest.xyz);
    vec4 x = positions[i];
    if (finite3(x.xyz)) prev_positions[i] = vec4(x.xyz, rest.w);
    if (rest.w == 0.0) {
        positions[i] = vec4(target, 0.0);
        return;
    }
    vec3 v = velocities[i].xyz;
#if GATHER
    v = mix(v, grid_velocity(x.xyz), friction);
#endif
    vec3 a = gravity;
    if (drag > 0.0) {
        vec3 w = vec3(0.0);
        if (wind_on != 0) w = wind_at(s, transform_point(head, rest_positions[s * uint(NV)].xyz), time);
        a += drag * (w - v);
    }
#if PENALTY
    a += penalty_acceleration(x.xyz);
#endif
    v = v * damping_factor + dt * a;
    float speed = length(v);
    if (speed > max_speed) v *= max_speed / speed;
    vec3 p = x.xyz + dt * v;
    if (global_stiffness > 0.0 && float(k) <= global_range * float(NV - 1) + 1e-4)
        p += global_stiffness * (target - p);
    positions[i] = vec4(p, rest.w);
}
