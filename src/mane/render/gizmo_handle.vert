#version 430
in vec3 in_position;
in vec4 in_ball;
in vec4 in_rgba;
uniform mat4 u_view_proj;
out vec3 v_normal;
out vec3 v_world;
out vec4 v_rgba;
void main() {
    v_normal = in_position;
    v_world = in_ball.xyz + in_position * in_ball.w;
    v_rgba = in_rgba;
    gl_Position = u_view_proj * vec4(v_world, 1.0);
}
