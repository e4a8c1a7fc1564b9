#version 430 core
// Emits each particle's 8 trilinear corners as 1-pixel points on the layers (z slices) of the
// grid's 3D texture; additive blending sums them.
layout(points) in;
layout(points, max_vertices = 8) out;

in VS_OUT {
    flat ivec3 base;
    vec3 frac;
    vec4 value;
} gs_in[];

out vec4 g_value;

void main() {
    if (gs_in[0].value.w == 0.0) return;
    vec3 f = gs_in[0].frac;
    for (int c = 0; c < 8; ++c) {
        ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        vec3 w3 = mix(vec3(1.0) - f, f, vec3(corner));
        float w = w3.x * w3.y * w3.z;
        if (w == 0.0) continue;
        ivec3 node = gs_in[0].base + corner;
        vec2 ndc = (vec2(node.xy) + 0.5) / float(GRID_RES) * 2.0 - 1.0;
        gl_Position = vec4(ndc, 0.0, 1.0);
        gl_Layer = node.z;
        g_value = w * gs_in[0].value;
        EmitVertex();
        EndPrimitive();
    }
}
