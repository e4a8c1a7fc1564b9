// Random subsets (OIT_METHOD 2): strand -> one of OIT_K subsets (its hashed random number); per
// pixel and subset the nearest fragment is kept. Stage 1: atomicMin of its 32-bit key; stage 2:
// the fragment whose key won writes its colour. The resolve sorts the <= K and blends them.
#if OIT_METHOD == 2
layout(early_fragment_tests) in;
layout(std430, binding = B_OIT_KEYS) coherent buffer OitKeys { uint oit_keys[]; };
layout(std430, binding = B_OIT_COLORS) writeonly buffer OitColors { uvec2 oit_colors[]; };
void oit_main() {
    int s = min(int(g_rand * float(OIT_K)), OIT_K - 1);
    int at = s * oit_pixels() + oit_pixel();
    uint key = oit_key32(g_depth);
#if OIT_STAGE == 1
    atomicMin(oit_keys[at], key);
#else
    if (oit_keys[at] == key)
        oit_colors[at] = oit_pack(oit_color());
#endif
}
#endif
