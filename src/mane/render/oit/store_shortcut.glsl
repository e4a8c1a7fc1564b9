// ShortCut (TressFX 3.1, OIT_METHOD 6). Stage 1: the 3 nearest depths per pixel (32-bit
// atomicMin bubbling of the depth bits) and the transmittance prod(1 - alpha) of every fragment
// (R16F target, blend ZERO, ONE_MINUS_SRC_COLOR). Stage 2: the fragments no farther than the
// 3rd depth are shaded and summed (RGBA16F, blend ONE, ONE): premultiplied colour and alpha.
// (TressFX's pass 2, the 3rd depth written for early-z, is a comparison in stage 2 here.)
#if OIT_METHOD == 6
layout(early_fragment_tests) in;
layout(std430, binding = B_OIT_KEYS) coherent buffer OitKeys { uint oit_keys[]; };
void oit_main() {
    int P = oit_pixels();
    int p = oit_pixel();
    uint key = floatBitsToUint(max(g_depth, 0.0));
#if OIT_STAGE == 1
    uint out_;
    OIT_INSERT_MIN(oit_keys, 3, P, p, key, out_)
    float a = oit_alpha();
    frag = vec4(a, a, a, a);
#else
    if (key > oit_keys[2 * P + p]) discard;
    frag = oit_color();
#endif
}
#endif
