#version 430
// ShortCut resolve (TressFX): the alpha-weighted mean colour of the 3 nearest fragments, with
// the opacity of all of them: colour = sum(c) / sum(a) * (1 - prod(1 - a)).
uniform sampler2D u_oit_transmittance;   // r: prod(1 - alpha) of every fragment
uniform sampler2D u_oit_accum;           // rgb: sum of premultiplied colours, a: sum of alphas
layout(location = 0) out vec4 frag;

void main() {
    ivec2 xy = ivec2(gl_FragCoord.xy);
    float T = clamp(texelFetch(u_oit_transmittance, xy, 0).r, 0.0, 1.0);
    vec4 acc = texelFetch(u_oit_accum, xy, 0);
    if (T >= 1.0 || acc.a <= 1e-6) discard;
    frag = vec4(acc.rgb / acc.a * (1.0 - T), 1.0 - T);
}
