#version 430
// The head: PASS 0 its colour (head_shading.glsl), PASS 1 its view depth, PASS 2 the id of its
// nearest triangle (head_shade.comp shades the pixel from it: head_pass.py).
#include "head_shading.glsl"
in vec3 h_pos;
in vec3 h_normal;
in float h_scalp;
in float h_depth;
#if PASS == 0
layout(location = 0) out vec4 frag;
#elif PASS == 1
layout(location = 0) out float frag_depth;
#else
layout(location = 0) out uint frag_id;
#endif
void main() {
#if PASS == 0
    frag = vec4(head_radiance(h_pos, h_normal, h_scalp), 1.0);
#elif PASS == 1
    frag_depth = h_depth;
#else
    frag_id = uint(gl_PrimitiveID);
#endif
}
