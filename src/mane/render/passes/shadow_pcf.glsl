// Shadow-map look-ups shared by light 0's maps (lighting.glsl, shadow_adsm.glsl, shadow_osm.glsl)
// and the other shadow-casting lights: where a point falls in a light's map, and percentage-
// closer filtering over the u_pcf x u_pcf texels around it (u_pcf: lighting.glsl's uniform).

// (uv in the light's map, depth along the light's forward in m) of P, for a light's
// view-projection, eye and unit forward.
vec3 light_space(mat4 view_proj, vec3 eye, vec3 dir, vec3 P) {
    vec4 c = view_proj * vec4(P, 1.0);
    vec2 uv = c.xy / c.w * 0.5 + 0.5;
    return vec3(uv, dot(P - eye, dir));
}

//     PCF_MEAN(RESULT, C, SIZE, T, EXPR)
// sets RESULT to the mean of EXPR over the texels T = C + (x, y) of a SIZE-texel map, x and y
// in [-(u_pcf / 2), u_pcf - 1 - u_pcf / 2] (row by row), each clamped to the map.
#define PCF_MEAN(RESULT, C, SIZE, T, EXPR) {                                  \
    int pcf_r_ = u_pcf / 2;                                                   \
    int pcf_lo_ = -pcf_r_, pcf_hi_ = u_pcf - 1 - pcf_r_;                      \
    float pcf_sum_ = 0.0, pcf_n_ = 0.0;                                       \
    for (int pcf_y_ = pcf_lo_; pcf_y_ <= pcf_hi_; ++pcf_y_)                   \
        for (int pcf_x_ = pcf_lo_; pcf_x_ <= pcf_hi_; ++pcf_x_) {             \
            ivec2 T = clamp((C) + ivec2(pcf_x_, pcf_y_), ivec2(0), (SIZE) - 1); \
            pcf_sum_ += (EXPR);                                               \
            pcf_n_ += 1.0;                                                    \
        }                                                                     \
    RESULT = pcf_sum_ / pcf_n_;                                               \
}
