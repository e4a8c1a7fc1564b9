#version 430 core
#if USE_GL_ARB_shader_viewport_layer_array
#extension GL_ARB_shader_viewport_layer_array : require
#else
#extension GL_AMD_vertex_shader_layer : require
#endif
// Grid friction, rasterised splat without a geometry shader: 8 points per particle (vertex
// 8 i + c is particle i's corner c), each a 1-pixel point at its node's (x, y) on layer z of the
// grid's 3D texture, carrying w (m v, m). Zero-weight corners are put outside the clip volume.
layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_PARTICLE_VELOCITIES) readonly buffer Velocities { vec4 velocities[]; };
#include "grid_nodes.glsl"

uniform float pinned_mass;
uniform float inv_mass_unit;

out vec4 g_value;

void main() {
    int i = gl_VertexID >> 3;
    int c = gl_VertexID & 7;
    vec4 p = positions[i];
    float m = particle_mass(p.w, pinned_mass, inv_mass_unit);
    NodeStencil s = node_stencil(p.xyz);
    ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    float w = corner_weight(s.frac, corner);
    gl_PointSize = 1.0;
    if (!(m > 0.0) || w == 0.0) {
        g_value = vec4(0.0);
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);   // clipped away
        gl_Layer = 0;
        return;
    }
    ivec3 node = s.base + corner;
    vec2 ndc = (vec2(node.xy) + 0.5) / float(GRID_RES) * 2.0 - 1.0;
    gl_Position = vec4(ndc, 0.0, 1.0);
    gl_Layer = node.z;
    g_value = w * vec4(m * velocities[i].xyz, m);
}
