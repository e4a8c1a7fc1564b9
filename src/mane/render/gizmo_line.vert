#version 430
in vec3 in_position;
in vec4 in_rgba;
uniform mat4 u_view_proj;
out vec4 v_rgba;
void main() { v_rgba = in_rgba; gl_Position = u_view_proj * vec4(in_position, 1.0); }
