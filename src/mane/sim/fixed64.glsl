// 64-bit fixed-point accumulation with two 32-bit atomics (no float or int64 atomics needed).
// A value v is stored as round(v * FIXED_SCALE) in two's complement, low word at [i], high at [i+1].
// Each addition is rounded to 1/FIXED_SCALE; the sum itself is exact and order-independent.
#ifndef FIXED_SCALE
#define FIXED_SCALE 4294967296.0lf   // 2^32
#endif
const double FIXED_WORD = 4294967296.0lf;

// (low, high) words of round(value * FIXED_SCALE); (0, 0) for a value that rounds to 0.
uvec2 fixed_words(float value) {
    double x = floor(double(value) * FIXED_SCALE + 0.5lf);
    double hi = floor(x / FIXED_WORD);
    return uvec2(uint(x - hi * FIXED_WORD), uint(int(hi)));
}

// Adds the 64-bit word pair w to ARR[I] (low), ARR[I + 1] (high), carrying from the low word.
// A macro, so that one body serves buffer and shared arrays alike.
#define FIXED_ADD_WORDS(ARR, I, W) {                                   \
        uint fixed_old_ = atomicAdd(ARR[(I)], (W).x);                  \
        uint fixed_carry_ = (fixed_old_ + (W).x < fixed_old_) ? 1u : 0u; \
        atomicAdd(ARR[(I) + 1u], (W).y + fixed_carry_);                \
    }

#ifdef FIXED_ACC
// acc must be a uint[] SSBO member named by the caller's macro FIXED_ACC.
void fixed_add(uint i, float value) {
    uvec2 w = fixed_words(value);
    if (w == uvec2(0u)) return;
    FIXED_ADD_WORDS(FIXED_ACC, i, w)
}

double fixed_load(uint i) {
    return (double(int(FIXED_ACC[i + 1u])) * FIXED_WORD + double(FIXED_ACC[i])) / FIXED_SCALE;
}
#endif
