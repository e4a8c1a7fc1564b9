// The compute rasteriser's per-sample buffers: the nearest strand segment (visibility) and
// the hair's accumulated coverage, as -sum(log(1 - coverage)) in 1/COVER_SCALE units.
// VIS64 (GL_NV_shader_atomic_int64): one 64-bit word per sample, window depth bits over the
// segment id, written by one atomicMin. Otherwise two 32-bit words: the depth bits by
// atomicMin in one dispatch, then id + 1 (atomicMax: the largest of equal depths; 0: none) in
// a second.
#if VIS64
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_NV_shader_atomic_int64 : require
layout(std430, binding = B_VIS) buffer Vis { uint64_t vis[]; };
#else
layout(std430, binding = B_VIS) buffer VisDepth { uint vis_depth[]; };
layout(std430, binding = B_VIS_ID) buffer VisId { uint vis_id[]; };
#endif
layout(std430, binding = B_COVER) buffer Cover { uint cover[]; };

#define VIS_EMPTY 0xFFFFFFFFu

// Samples are stored pixel by pixel, a pixel's grid x grid samples together (row by row), so
// that the shading pass reads a pixel's samples at once. q: the sample; width: pixels per row.
uint sample_index(ivec2 q, int width, int grid) {
    ivec2 p = q / grid;
    ivec2 s = q - p * grid;
    return (uint(p.y) * uint(width) + uint(p.x)) * uint(grid * grid) + uint(s.y * grid + s.x);
}
#define COVER_SCALE 4096.0
// past this a sample's coverage is not added to (hair_raster.comp): alpha 1 - e^-12, within
// 6e-6 of 1, below half an RGBA16F step at 1.0 (1 - e^-7 measured no faster on the H200's
// close-ups, 2026-12-02)
#define COVER_SATURATED 49152u

uint cover_units(float coverage) {
    return uint(-log(1.0 - clamp(coverage, 0.0, 0.9999)) * COVER_SCALE + 0.5);
}

float cover_alpha(uint units) {
    return 1.0 - exp(-float(units) / COVER_SCALE);
}
