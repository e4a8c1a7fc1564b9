#version 430
in vec3 in_position;
in vec3 in_normal;
in float in_scalp;
uniform mat4 u_view_proj;
uniform mat4 u_head_model;  // the head's rigid motion (identity when still)
out vec3 h_pos;
out vec3 h_normal;
out float h_scalp;
out float h_depth;
uniform vec3 u_eye;
uniform vec3 u_view_dir;
void main() {
    vec3 p = (u_head_model * vec4(in_position, 1.0)).xyz;
    h_pos = p;
    h_normal = mat3(u_head_model) * in_normal;
    h_scalp = in_scalp;
    h_depth = dot(p - u_eye, u_view_dir);
    gl_Position = u_view_proj * vec4(p, 1.0);
}
