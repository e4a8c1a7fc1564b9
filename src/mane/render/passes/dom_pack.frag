#version 430
// Copies the hair's first light depth z0 into the opacity texture's alpha (colour mask: A only).
uniform sampler2D u_dom_depth;
layout(location = 0) out vec4 frag;
void main() {
    frag = vec4(0.0, 0.0, 0.0, texelFetch(u_dom_depth, ivec2(gl_FragCoord.xy), 0).r);
}
