// The OIT hair fragment's main(): after hair_main.glsl (main renamed oit_hair_shade) and the
// shading model. Each method's store_*.glsl defines oit_main() for its OIT_STAGE.
#include "oit_common.glsl"

uniform float u_oit_opacity;    // strand opacity in the camera view (x coverage alpha)
uniform ivec2 u_oit_size;       // pixels of the OIT targets (the render size)
uniform vec2 u_oit_depth_range; // the hair's view depth range this frame (m): 24-bit keys

// the shaded fragment, premultiplied, with the strand opacity (runs the hair shading)
vec4 oit_color() {
    oit_hair_shade();
    return frag * u_oit_opacity;
}
float oit_alpha() { return clamp(g_alpha * u_oit_opacity, 0.0, 1.0); }
ivec2 oit_xy() { return ivec2(gl_FragCoord.xy); }
int oit_pixel() { ivec2 p = ivec2(gl_FragCoord.xy); return p.y * u_oit_size.x + p.x; }
int oit_pixels() { return u_oit_size.x * u_oit_size.y; }
// 8 bits that tell fragments of one pixel apart (strand and place along it)
uint oit_frag_id() { return pcg_hash(floatBitsToUint(g_rand) ^ (floatBitsToUint(g_s) * 2654435761u)) & 255u; }
// a 32-bit key: 24-bit depth, then the id (ties between distinct fragments are rare)
uint oit_key32(float depth) { return (oit_depth24(depth, u_oit_depth_range) << 8) | oit_frag_id(); }

// keep the K smallest 32-bit values of a pixel, ascending, in keys[i * P + pixel] (lock-free:
// each atomicMin keeps the smaller value and the larger one moves on to the next slot).
// Returns the value pushed out of the last slot (OIT_END when one was free).
#define OIT_INSERT_MIN(KEYS, K, P, PIX, VALUE, OUT) { \
    uint v_ = (VALUE); \
    for (int i_ = 0; i_ < (K); ++i_) { \
        uint old_ = atomicMin(KEYS[i_ * (P) + (PIX)], v_); \
        if (old_ == OIT_END) { v_ = OIT_END; break; } \
        v_ = max(old_, v_); \
    } \
    OUT = v_; }

#include "store_sorted_blending.glsl"
#include "store_random_subsets.glsl"
#include "store_ppll.glsl"
#include "store_k_buffer.glsl"
#include "store_shortcut.glsl"

#ifndef OIT_OWN_MAIN
void main() {
    oit_main();
}
#endif
