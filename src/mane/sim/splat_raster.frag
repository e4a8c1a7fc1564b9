#version 430 core
in vec4 g_value;
layout(location = 0) out vec4 out_value;   // RGBA32F, blended GL_ONE, GL_ONE
void main() {
    out_value = g_value;
}
