#version 430 core
// Clear a single-sample colour texture by imageStore: on GPUs built for computing (H100/H200)
// the raster units' clear of a 1080p RGBA16F target takes ~30x longer (mane/gpu/clear.py).
layout(local_size_x = 16, local_size_y = 16) in;
layout(FORMAT, binding = IMG_CLEAR) writeonly uniform image2D target;
uniform ivec2 size;
uniform vec4 value;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x < size.x && p.y < size.y)
        imageStore(target, p, value);
}
