#version 430
in vec3 in_position;
in vec3 in_normal;
in float in_scalp;
uniform mat4 u_view_proj;
out vec3 h_pos;
out vec3 h_normal;
out float h_scalp;
out float h_depth;
uniform vec3 u_eye;
uniform vec3 u_view_dir;
void main() {
    h_pos = in_position;
    h_normal = in_normal;
    h_scalp = in_scalp;
    h_depth = dot(in_position - u_eye, u_view_dir);
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
