#version 430
in vec3 in_position;
uniform mat4 u_view_proj;
uniform vec4 u_sphere;   // centre, radius
out vec3 v_normal;
out vec3 v_world;
void main() {
    v_normal = in_position;
    v_world = u_sphere.xyz + in_position * u_sphere.w;
    gl_Position = u_view_proj * vec4(v_world, 1.0);
}
