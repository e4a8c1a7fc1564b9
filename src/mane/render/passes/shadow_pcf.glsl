// Shadow-map look-ups shared by light 0's maps (lighting.glsl, shadow_adsm.glsl, shadow_osm.glsl)
// and the other shadow-casting lights: where a point falls in a light's map, and percentage-
// closer filtering over a u_pcf x u_pcf texel box around it, bilinearly weighted (u_pcf:
// lighting.glsl's uniform).

// (uv in the light's map, depth along the light's forward in m) of P, for a light's
// view-projection, eye and unit forward.
vec3 light_space(mat4 view_proj, vec3 eye, vec3 dir, vec3 P) {
    vec4 c = view_proj * vec4(P, 1.0);
    vec2 uv = c.xy / c.w * 0.5 + 0.5;
    return vec3(uv, dot(P - eye, dir));
}

//     PCF_BILINEAR(RESULT, X, SIZE, T, EXPR)
// sets RESULT to the mean of EXPR over a box of u_pcf x u_pcf texels centred on X (the point in
// continuous texel units: texel (i, j)'s centre at (i, j), i.e. uv * size - 0.5), each texel
// weighted by its overlap with the box: the (u_pcf + 1)^2 texels T the box touches (clamped to
// the SIZE-texel map), the first and last row and column weighted 1 - f and f. With u_pcf = 1
// it is bilinear interpolation of EXPR between the 4 nearest texels: the result moves
// continuously with X, with no steps at texel edges (what a box of nearest texels shows).
// PCF_BOX(RESULT, X, SIZE, T, N, EXPR) is the same over an N x N box (PCF_BILINEAR: N = u_pcf).
#define PCF_BOX(RESULT, X, SIZE, T, N, EXPR) {                              \
    vec2 pcf_s_ = (X) - 0.5 * float((N) - 1);                               \
    vec2 pcf_b_ = floor(pcf_s_);                                              \
    vec2 pcf_f_ = pcf_s_ - pcf_b_;                                            \
    ivec2 pcf_c_ = ivec2(pcf_b_);                                             \
    float pcf_sum_ = 0.0;                                                     \
    for (int pcf_j_ = 0; pcf_j_ <= (N); ++pcf_j_) {                         \
        float pcf_wy_ = pcf_j_ == 0 ? 1.0 - pcf_f_.y : (pcf_j_ == (N) ? pcf_f_.y : 1.0); \
        for (int pcf_i_ = 0; pcf_i_ <= (N); ++pcf_i_) {                     \
            float pcf_wx_ = pcf_i_ == 0 ? 1.0 - pcf_f_.x : (pcf_i_ == (N) ? pcf_f_.x : 1.0); \
            ivec2 T = clamp(pcf_c_ + ivec2(pcf_i_, pcf_j_), ivec2(0), (SIZE) - 1); \
            pcf_sum_ += pcf_wx_ * pcf_wy_ * (EXPR);                           \
        }                                                                     \
    }                                                                         \
    RESULT = pcf_sum_ / float((N) * (N));                                 \
}
#define PCF_BILINEAR(RESULT, X, SIZE, T, EXPR) PCF_BOX(RESULT, X, SIZE, T, u_pcf, EXPR)
