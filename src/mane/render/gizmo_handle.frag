#version 430
in vec3 v_normal;
in vec3 v_world;
in vec4 v_rgba;
uniform vec3 u_eye;
uniform float u_fade;
out vec4 frag;
void main() {
    float facing = abs(dot(normalize(v_normal), normalize(u_eye - v_world)));
    float a = v_rgba.a * u_fade;
    frag = vec4(v_rgba.rgb * (0.55 + 0.45 * facing) * a, a);    // lit from the viewer, premultiplied
}
