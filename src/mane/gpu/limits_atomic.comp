#version 430
// mane bench limits: atomicMin throughput into a buffer of u_words words (the compute
// rasteriser's per-sample visibility buffer: 1920x1080x4 samples), u_ops atomics a thread.
// PATTERN 0: every operation at a random word (a hash of thread and operation);
// PATTERN 1: a thread's operations at consecutive words from a random start (one thread
// walking a segment's samples, as hair_raster.comp does).
// ATOMIC64: 64-bit words (GL_NV_shader_atomic_int64), the value over the word index as the
// compute rasteriser packs depth over segment id; otherwise 32-bit words.
#if ATOMIC64
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_NV_shader_atomic_int64 : require
layout(std430, binding = B_WORDS) buffer Words { uint64_t words[]; };
#else
layout(std430, binding = B_WORDS) buffer Words { uint words[]; };
#endif
layout(local_size_x = 256) in;
uniform uint u_words;
uniform uint u_threads;
uniform uint u_ops;
uniform uint u_seed;

uint pcg(uint v) {   // PCG-RXS-M-XS 32 (Jarzynski and Olano 2020)
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint word_of(uint h) {   // h in [0, 2^32) -> [0, u_words) without a division
    uint hi, lo;
    umulExtended(h, u_words, hi, lo);
    return hi;
}

void main() {
    uint t = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
             + gl_LocalInvocationID.x;
    if (t >= u_threads) return;
    uint h = pcg(t ^ u_seed);
    uint idx = word_of(h);
    for (uint k = 0u; k < u_ops; ++k) {
        h = pcg(h);
#if PATTERN == 0
        idx = word_of(h);
#else
        idx = idx + 1u < u_words ? idx + 1u : 0u;
#endif
#if ATOMIC64
        atomicMin(words[idx], (uint64_t(h) << 32) | uint64_t(idx));
#else
        atomicMin(words[idx], h);
#endif
    }
}
