#version 430
// A still scene's running mean of its frames (accumulate.py), a thread a pixel:
// mean += (frame - mean) * u_weight, u_weight = 1 / k for the k-th frame (1: the mean starts).
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D u_frame;   // this frame's HDR colour (premultiplied, alpha = coverage)
uniform float u_weight;
layout(rgba32f, binding = IMG_ACCUM) uniform image2D u_mean;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_mean)))) return;
    vec4 c = texelFetch(u_frame, p, 0);
    vec4 m = u_weight >= 1.0 ? c : imageLoad(u_mean, p);
    imageStore(u_mean, p, m + (c - m) * u_weight);
}
