// K-buffer (OIT_METHOD 4): the OIT_K nearest fragments per pixel, ascending, in slot-major
// arrays (slot i of pixel p at i * P + p). The fragments pushed out go to the tail targets,
// blended order-independently: RT0 = (sum of premultiplied colours, product of (1 - alpha)),
// RT1.r = sum of alphas (blend: rgb ONE, ONE; alpha ZERO, ONE_MINUS_SRC_ALPHA).
//
// OIT_KBUF_MODE 0 "atomic32" (any GL 4.3; llvmpipe): two geometry passes. Stage 1 keeps the K
//   smallest 32-bit keys (24-bit depth | 8-bit id) by atomicMin bubbling; stage 2 shades every
//   fragment: the one whose key is in a slot writes its colour there, the others go to the tail.
// OIT_KBUF_MODE 1 "atomic64" (GL_NV_shader_atomic_int64): one pass, 64-bit keys
//   depth24 | colour40 bubbled with 64-bit atomicMin; the value out of the last slot is the tail.
// OIT_KBUF_MODE 2 "interlock" (GL_ARB_fragment_shader_interlock): one pass, an insertion into
//   sorted depth / half-colour slots inside the pixel's critical section.
#if OIT_METHOD == 4
layout(early_fragment_tests) in;
layout(location = 1) out vec4 oit_tail_alpha;

void oit_tail(vec4 c) {
    frag = c;
    oit_tail_alpha = vec4(c.a, 0.0, 0.0, 0.0);
}
void oit_no_tail() {
    frag = vec4(0.0);
    oit_tail_alpha = vec4(0.0);
}

#if OIT_KBUF_MODE == 0
layout(std430, binding = B_OIT_KEYS) coherent buffer OitKeys { uint oit_keys[]; };
layout(std430, binding = B_OIT_COLORS) writeonly buffer OitColors { uvec2 oit_colors[]; };
void oit_main() {
    int P = oit_pixels();
    int p = oit_pixel();
    uint key = oit_key32(g_depth);
#if OIT_STAGE == 1
    uint out_;
    OIT_INSERT_MIN(oit_keys, OIT_K, P, p, key, out_)
#else
    vec4 c = oit_color();
    for (int i = 0; i < OIT_K; ++i) {
        uint s = oit_keys[i * P + p];
        if (s == key) {
            oit_colors[i * P + p] = oit_pack(c);
            oit_no_tail();
            return;
        }
        if (s > key) break;
    }
    oit_tail(c);
#endif
}

#elif OIT_KBUF_MODE == 1
layout(std430, binding = B_OIT_KEYS) coherent buffer OitKeys64 { uint64_t oit_keys64[]; };
void oit_main() {
    int P = oit_pixels();
    int p = oit_pixel();
    vec4 c = oit_color();
    uvec2 c40 = oit_pack40(c);
    uint64_t v = packUint2x32(uvec2(c40.x, (oit_depth24(g_depth, u_oit_depth_range) << 8) | c40.y));
    const uint64_t EMPTY = 0xFFFFFFFFFFFFFFFFul;
    for (int i = 0; i < OIT_K; ++i) {
        uint64_t old = atomicMin(oit_keys64[i * P + p], v);
        if (old == EMPTY) { v = EMPTY; break; }
        v = max(old, v);
    }
    if (v != EMPTY) {
        uvec2 w = unpackUint2x32(v);
        oit_tail(oit_unpack40(uvec2(w.x, w.y & 255u)));
    } else {
        oit_no_tail();
    }
}

#elif OIT_KBUF_MODE == 2
layout(pixel_interlock_ordered) in;
layout(std430, binding = B_OIT_KEYS) coherent buffer OitDepths { float oit_depths[]; };
layout(std430, binding = B_OIT_COLORS) coherent buffer OitColors { uvec2 oit_colors[]; };
// begin/endInvocationInterlockARB may only be called in main(), outside control flow
#define OIT_OWN_MAIN 1
void main() {
    int P = oit_pixels();
    int p = oit_pixel();
    vec4 c = oit_color();
    float d = g_depth;
    uvec2 pc = oit_pack(c);
    beginInvocationInterlockARB();
    for (int i = 0; i < OIT_K; ++i) {
        float di = oit_depths[i * P + p];
        if (d < di) {          // keep the nearer here, carry the farther on
            uvec2 ci = oit_colors[i * P + p];
            oit_depths[i * P + p] = d;
            oit_colors[i * P + p] = pc;
            d = di;
            pc = ci;
            if (di >= 3.0e38) break;   // was empty: nothing more to carry
        }
    }
    endInvocationInterlockARB();
    if (d < 3.0e38) oit_tail(oit_unpack(pc));
    else oit_no_tail();
}
#endif
#endif
