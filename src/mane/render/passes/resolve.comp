#version 430
// HDR (premultiplied, alpha = coverage) -> tone mapped, over the background, sRGB, a thread an
// output pixel (a compute pass: on an H200 a full-screen fragment pass went through its few
// raster units, 0.24 ms at 1080p).
// SUPERSAMPLE 2: Chen's 5-tap down-sample (the centre and 4 diagonal bilinear taps).
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D u_hdr;
uniform vec3 u_background;   // linear
uniform float u_exposure;
layout(rgba8, binding = IMG_OUTPUT) writeonly uniform image2D u_output;

vec3 aces(vec3 x) {  // Narkowicz's fit of the ACES filmic curve
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
vec3 tone(vec3 x) {
#if TONE_MAP == 0
    return aces(x);
#elif TONE_MAP == 1
    return x / (1.0 + x);
#else
    return clamp(x, 0.0, 1.0);
#endif
}
vec3 srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_output)))) return;
#if SUPERSAMPLE == 2
    vec2 texel = 1.0 / vec2(textureSize(u_hdr, 0));
    vec2 uv = (vec2(p) + 0.5) * 2.0 * texel;   // the output pixel's centre = a hi-res texel corner
    vec4 c = textureLod(u_hdr, uv, 0.0);
    c += textureLod(u_hdr, uv + vec2(-1.0, -1.0) * texel, 0.0);
    c += textureLod(u_hdr, uv + vec2(1.0, -1.0) * texel, 0.0);
    c += textureLod(u_hdr, uv + vec2(-1.0, 1.0) * texel, 0.0);
    c += textureLod(u_hdr, uv + vec2(1.0, 1.0) * texel, 0.0);
    c *= 0.2;
#else
    vec4 c = texelFetch(u_hdr, p, 0);
#endif
    float a = clamp(c.a, 0.0, 1.0);
    vec3 rgb = a > 1e-5 ? c.rgb / max(c.a, 1e-5) : vec3(0.0);
    vec3 mapped = tone(rgb * u_exposure);
    // composite in linear light, encode once
    vec3 bg = u_background;
    vec3 outc = mapped * a + bg * (1.0 - a);
    imageStore(u_output, p, vec4(srgb(outc), 1.0));
}
