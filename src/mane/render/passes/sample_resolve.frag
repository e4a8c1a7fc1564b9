#version 430
// A multisampled target's samples averaged into one pixel, sample i fetched from the pixel
// u_offset[i] away (sample_resolve.py): a still picture's frame on the hardware rasteriser, whose
// image moved by a sub-pixel offset, takes for each pixel the samples that fell inside it.
// SAMPLES: the target's samples. POSITIONS: write the samples' positions (sample_positions.frag's
// target) along x instead.
uniform sampler2DMS u_src;
uniform ivec2 u_offset[SAMPLES];
out vec4 frag;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
#if POSITIONS
    frag = texelFetch(u_src, ivec2(0), p.x);
#else
    ivec2 hi = textureSize(u_src) - 1;
    vec4 sum = vec4(0.0);
    for (int i = 0; i < SAMPLES; ++i)
        sum += texelFetch(u_src, clamp(p + u_offset[i], ivec2(0), hi), i);
    frag = sum / float(SAMPLES);
#endif
}
