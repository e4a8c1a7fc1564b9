#version 430
// HDR (premultiplied, alpha = coverage) -> tone mapped, over the background, sRGB.
// SUPERSAMPLE 2: Chen's 5-tap down-sample (the centre and 4 diagonal bilinear taps).
uniform sampler2D u_hdr;
uniform vec3 u_background;   // linear
uniform float u_exposure;
in vec2 f_uv;
layout(location = 0) out vec4 frag;

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
#if SUPERSAMPLE == 2
    vec2 texel = 1.0 / vec2(textureSize(u_hdr, 0));
    vec2 uv = gl_FragCoord.xy * 2.0 * texel;   // the output pixel's centre = a hi-res texel corner
    vec4 c = texture(u_hdr, uv);
    c += texture(u_hdr, uv + vec2(-1.0, -1.0) * texel);
    c += texture(u_hdr, uv + vec2(1.0, -1.0) * texel);
    c += texture(u_hdr, uv + vec2(-1.0, 1.0) * texel);
    c += texture(u_hdr, uv + vec2(1.0, 1.0) * texel);
    c *= 0.2;
#else
    vec4 c = texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0);
#endif
    float a = clamp(c.a, 0.0, 1.0);
    vec3 rgb = a > 1e-5 ? c.rgb / max(c.a, 1e-5) : vec3(0.0);
    vec3 mapped = tone(rgb * u_exposure);
    // composite in linear light, encode once
    vec3 bg = u_background;
    vec3 outc = mapped * a + bg * (1.0 - a);
    frag = vec4(srgb(outc), 1.0);
}
