#version 330
uniform sampler2D u_image;
in vec2 uv;
out vec4 frag;
void main() { frag = vec4(texture(u_image, uv).rgb, 1.0); }
