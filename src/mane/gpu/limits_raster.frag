#version 430
// mane bench limits: a trivial fragment shader (the raster units', not the shaders', limit).
out vec4 f_color;

void main() {
    f_color = vec4(0.25, 0.5, 0.75, 1.0);
}
