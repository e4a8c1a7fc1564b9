// 64-bit fixed-point accumulation with two 32-bit atomics (no float or int64 atomics needed).
// A value v is stored as round(v * FIXED_SCALE) in two's complement, low word at [i], high at [i+1].
// Each addition is rounded to 1/FIXED_SCALE; the sum itself is exact and order-independent.
#ifndef FIXED_SCALE
#define FIXED_SCALE 4294967296.0lf   // 2^32
#endif
const double FIXED_WORD = 4294967296.0lf;

// acc must be a uint[] SSBO member named by the caller's macro FIXED_ACC.
void fixed_add(uint i, float value) {
    double x = floor(double(value) * FIXED_SCALE + 0.5lf);
    if (x == 0.0lf) return;
    double hi = floor(x / FIXED_WORD);
    uint lo = uint(x - hi * FIXED_WORD);
    uint old = atomicAdd(FIXED_ACC[i], lo);
    uint carry = (old + lo < old) ? 1u : 0u;
    atomicAdd(FIXED_ACC[i + 1u], uint(int(hi)) + carry);
}

double fixed_load(uint i) {
    return (double(int(FIXED_ACC[i + 1u])) * FIXED_WORD + double(FIXED_ACC[i])) / FIXED_SCALE;
}
