// Per-pixel linked lists (A-buffer, OIT_METHOD 3; DBK-buffer, OIT_METHOD 5). Head pointers: an
// r32ui image (OIT_END = empty); nodes: uvec4 {rg half, ba half, depth bits, next}; counter[0]:
// fragments offered this frame (beyond u_oit_capacity they are counted and dropped).
#if OIT_METHOD == 3 || OIT_METHOD == 5
layout(binding = IMG_OIT_HEADS, r32ui) uniform coherent uimage2D u_oit_heads;
layout(std430, binding = B_PPLL_NODES) writeonly buffer OitNodes { uvec4 oit_nodes[]; };
layout(std430, binding = B_PPLL_COUNTER) coherent buffer OitCounter { uint oit_counter[]; };
uniform uint u_oit_capacity;

void ppll_append(vec4 c, float depth) {
    uint idx = atomicAdd(oit_counter[0], 1u);
    if (idx >= u_oit_capacity) return;            // the pool is full: counted, not stored
    uint prev = imageAtomicExchange(u_oit_heads, oit_xy(), idx);
    oit_nodes[idx] = uvec4(oit_pack(c), floatBitsToUint(depth), prev);
}
#endif

#if OIT_METHOD == 3
layout(early_fragment_tests) in;    // the head's depth hides fragments before they are stored
void oit_main() {
    ppll_append(oit_color(), g_depth);
}
#endif

// DBK-buffer. Stage 1: the nearest hair depth per pixel (atomicMin of the float bits, all > 0).
// Stage 2: fragments within u_oit_shift of it go to the lists; one behind sets OIT_BEHIND.
// Stage 3: the hair behind the layer, depth-tested and written (discard: late tests): opaque
// (Hunz; OIT_DBK_BEHIND_OPAQUE) or premultiplied-blended with its alpha.
#if OIT_METHOD == 5
layout(binding = IMG_OIT_FRONT, r32ui) uniform coherent uimage2D u_oit_front;
uniform float u_oit_shift;
#if OIT_STAGE != 3
layout(early_fragment_tests) in;
#endif
void oit_main() {
#if OIT_STAGE == 1
    imageAtomicMin(u_oit_front, oit_xy(), floatBitsToUint(max(g_depth, 0.0)));
#else
    uint f = imageLoad(u_oit_front, oit_xy()).r;
    float z0 = uintBitsToFloat(f & ~OIT_BEHIND);
    bool inside = g_depth <= z0 + u_oit_shift;
#if OIT_STAGE == 2
    if (inside)
        ppll_append(oit_color(), g_depth);
    else if ((f & OIT_BEHIND) == 0u)
        imageAtomicOr(u_oit_front, oit_xy(), OIT_BEHIND);
#else
    if (inside) discard;
    vec4 c = oit_color();
    if (c.a <= 0.0) discard;
#if OIT_DBK_BEHIND_OPAQUE
    frag = vec4(c.rgb / max(c.a, 1e-6), 1.0);      // Hunz: opaque
#else
    frag = c;                                        // blended with its alpha (depth writes on)
#endif
#endif
#endif
}
#endif
