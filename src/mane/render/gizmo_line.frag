#version 430
in vec4 v_rgba;
uniform float u_fade;
out vec4 frag;
void main() { float a = v_rgba.a * u_fade; frag = vec4(v_rgba.rgb * a, a); }
