#version 430
// The hair's depth pre-pass (MSAA): alpha to coverage writes the depth of the samples a
// strand covers; the shading pass then runs once per pixel and front strand (depth test
// LEQUAL, no depth writes: early depth test), not once per overlapping strand.
in float g_alpha;
layout(location = 0) out vec4 frag;
void main() {
    frag = vec4(0.0, 0.0, 0.0, g_alpha);
}
