// The grid's box, written on the GPU by bounds.comp (GridBounds) and read by every grid kernel.
// std430, 64 bytes: the reduction's order-preserving keys, then the padded box.
#ifndef BOUNDS_BINDING
#define BOUNDS_BINDING 7
#endif
layout(std430, binding = BOUNDS_BINDING) buffer GridBoundsBlock {
    int bounds_keys[8];     // [0..2]: float_key(min xyz), [4..6]: float_key(max xyz)
    vec4 bounds_lo;         // xyz: padded box minimum (metres)
    vec4 bounds_hi;         // xyz: padded box maximum (metres)
};
