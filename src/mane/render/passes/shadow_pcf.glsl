// Shadow-map look-ups shared by light 0's maps (lighting.glsl, shadow_adsm.glsl, shadow_osm.glsl)
// and the other shadow-casting lights: where a point falls in a light's map, and percentage-
// closer filtering over a PCF x PCF texel box around it, bilinearly weighted (PCF:
// lighting.glsl's define).

// (uv in the light's map, depth along the light's forward in m) of P, for a light's
// view-projection, eye and unit forward.
vec3 light_space(mat4 view_proj, vec3 eye, vec3 dir, vec3 P) {
    vec4 c = view_proj * vec4(P, 1.0);
    vec2 uv = c.xy / c.w * 0.5 + 0.5;
    return vec3(uv, dot(P - eye, dir));
}

//     PCF_BILINEAR(RESULT, X, SIZE, T, EXPR)
// sets RESULT to the mean of EXPR over a box of PCF x PCF texels centred on X (the point in
// continuous texel units: texel (i, j)'s centre at (i, j), i.e. uv * size - 0.5), each texel
// weighted by its overlap with the box: the (PCF + 1)^2 texels T the box touches (clamped to
// the SIZE-texel map), the first and last row and column weighted 1 - f and f. With PCF = 1
// it is bilinear interpolation of EXPR between the 4 nearest texels: the result moves
// continuously with X, with no steps at texel edges (what a box of nearest texels shows).
// PCF_BOX(RESULT, X, SIZE, T, N, EXPR) is the same over an N x N box (PCF_BILINEAR: N = PCF, a compile-time constant).
#define PCF_BOX_OF(TYPE, RESULT, X, SIZE, T, N, EXPR) {                   \
    vec2 pcf_s_ = (X) - 0.5 * float((N) - 1);                               \
    vec2 pcf_b_ = floor(pcf_s_);                                              \
    vec2 pcf_f_ = pcf_s_ - pcf_b_;                                            \
    ivec2 pcf_c_ = ivec2(pcf_b_);                                             \
    TYPE pcf_sum_ = TYPE(0.0);                                                \
    for (int pcf_j_ = 0; pcf_j_ <= (N); ++pcf_j_) {                         \
        float pcf_wy_ = pcf_j_ == 0 ? 1.0 - pcf_f_.y : (pcf_j_ == (N) ? pcf_f_.y : 1.0); \
        for (int pcf_i_ = 0; pcf_i_ <= (N); ++pcf_i_) {                     \
            float pcf_wx_ = pcf_i_ == 0 ? 1.0 - pcf_f_.x : (pcf_i_ == (N) ? pcf_f_.x : 1.0); \
            ivec2 T = clamp(pcf_c_ + ivec2(pcf_i_, pcf_j_), ivec2(0), (SIZE) - 1); \
            pcf_sum_ += (pcf_wx_ * pcf_wy_) * (EXPR);                         \
        }                                                                     \
    }                                                                         \
    RESULT = pcf_sum_ / float((N) * (N));                                 \
}
#define PCF_BOX(RESULT, X, SIZE, T, N, EXPR) PCF_BOX_OF(float, RESULT, X, SIZE, T, N, EXPR)
// PCF_BOX of a vec2 EXPR: two box means from one pass over the texels.
#define PCF_BOX2(RESULT, X, SIZE, T, N, EXPR) PCF_BOX_OF(vec2, RESULT, X, SIZE, T, N, EXPR)
#define PCF_BILINEAR(RESULT, X, SIZE, T, EXPR) PCF_BOX(RESULT, X, SIZE, T, PCF, EXPR)

// PCF_BILINEAR's box of a depth comparison, texel depth >= ref lit, by textureGather: 4 texels
// a fetch (2x2 blocks, gathered at the corner they share, so the texels are the ones the box
// names whatever the sampler's rounding), the same weights. The map must clamp to its edge
// (light_depth_target), as PCF_BILINEAR clamps its texels. A CPU rasteriser (llvmpipe) fetches
// the 4 texels for about the cost of one texelFetch.
float pcf_compare(sampler2D map, vec2 X, float ref) {
    vec2 inv = 1.0 / vec2(textureSize(map, 0));
    vec2 s = X - 0.5 * float(PCF - 1);
    vec2 b = floor(s);
    vec2 f = s - b;
    float sum = 0.0;
    for (int j = 0; j <= PCF; j += 2) {
        float wy0 = j == 0 ? 1.0 - f.y : (j == PCF ? f.y : 1.0);
        float wy1 = j + 1 < PCF ? 1.0 : (j + 1 == PCF ? f.y : 0.0);
        for (int i = 0; i <= PCF; i += 2) {
            float wx0 = i == 0 ? 1.0 - f.x : (i == PCF ? f.x : 1.0);
            float wx1 = i + 1 < PCF ? 1.0 : (i + 1 == PCF ? f.x : 0.0);
            // (x, y, z, w) = texels (i0, j1), (i1, j1), (i1, j0), (i0, j0)
            vec4 lit = vec4(greaterThanEqual(textureGather(map, (b + vec2(i, j) + 1.0) * inv), vec4(ref)));
            sum += dot(lit, vec4(wx0 * wy1, wx1 * wy1, wx1 * wy0, wx0 * wy0));
        }
    }
    return sum / float(PCF * PCF);
}
