#version 430
in vec3 v_normal;
in vec3 v_world;
uniform vec3 u_eye;
uniform vec3 u_color;
uniform float u_alpha;
out vec4 frag;
void main() {
    vec3 N = normalize(v_normal);
    vec3 V = normalize(u_eye - v_world);
    float rim = pow(1.0 - abs(dot(N, V)), 2.0);
    float lambert = 0.35 + 0.65 * max(dot(N, normalize(vec3(-0.4, 0.8, 0.5))), 0.0);
    float a = clamp(u_alpha + 0.5 * rim, 0.0, 1.0);
    frag = vec4(u_color * lambert * a, a);    // premultiplied, like the hair
}
