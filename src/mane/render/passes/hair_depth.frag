#version 430
// The hair's depth pre-pass (MSAA): the strand's coverage as a sample mask (coverage_mask.glsl)
// writes the depth of the samples it covers; the shading pass then runs once per pixel and
// front strand (depth test LEQUAL, no depth writes: early depth test, the same mask), not once
// per overlapping strand.
#include "coverage_mask.glsl"
in float g_alpha;
flat in int g_strand;
layout(location = 0) out vec4 frag;
void main() {
    gl_SampleMask[0] = coverage_mask(g_alpha, g_strand, ivec2(gl_FragCoord.xy));
    frag = vec4(0.0, 0.0, 0.0, 1.0);
}
