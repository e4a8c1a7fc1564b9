// Scan conversion of one strand segment in a compute shader (the compute rasteriser: hair
// drawn without the GPU's raster units, as Unreal's and Frostbite's strand rasterisers do).
//
//     #define RASTER_VISIT(Q, Z, COV) ...   // before the include: what to do at sample Q
//     #include "raster_segment.glsl"
//     raster_segment(a, b, za, zb, ha, hb, ca, cb, size);
//
// a, b: the end points in sample units (sample (i, j) has its centre at (i + 0.5, j + 0.5));
// za, zb: depths, interpolated linearly along the segment on screen (window depth or an
// orthographic view's depth: both affine in screen space); ha, hb: half widths (samples);
// ca, cb: coverages. The segment is a quad of width 2h across it: along its major axis every
// sample column whose centre lies in [a, b) (half-open, so that strips of segments meet
// without overlap), and across it the samples whose centres lie within h / cos(angle) of
// the centre line, half-open again (h = 0.5: exactly one sample per column). Samples
// outside [0, size) are skipped; at most RASTER_MAX_STEPS columns and RASTER_MAX_SPAN
// samples across, so that a hostile segment cannot stall the GPU.
#ifndef RASTER_MAX_STEPS
#define RASTER_MAX_STEPS 8192
#endif
#ifndef RASTER_MAX_SPAN
#define RASTER_MAX_SPAN 64
#endif

void raster_segment(vec2 a, vec2 b, float za, float zb, float ha, float hb, float ca, float cb, ivec2 size) {
    vec2 d = b - a;
    bool steep = abs(d.y) > abs(d.x);
    if (steep) { a = a.yx; b = b.yx; d = d.yx; size = size.yx; }
    if (d.x < 0.0) {   // walk left to right
        vec2 tv = a; a = b; b = tv; d = -d;
        float t = za; za = zb; zb = t;
        t = ha; ha = hb; hb = t;
        t = ca; ca = cb; cb = t;
    }
    if (!(d.x > 1e-6)) return;   // shorter than a sample along its major axis (or NaN)
    float inv_cos = length(d) / d.x;
    int x0 = max(int(ceil(a.x - 0.5)), 0);
    int x1 = min(min(int(ceil(b.x - 0.5)) - 1, size.x - 1), x0 + RASTER_MAX_STEPS);
    for (int x = x0; x <= x1; ++x) {
        float t = (float(x) + 0.5 - a.x) / d.x;
        float y = a.y + t * d.y;
        float h = min(mix(ha, hb, t) * inv_cos, float(RASTER_MAX_SPAN));
        int y0 = max(int(ceil(y - h - 0.5)), 0);
        int y1 = min(int(ceil(y + h - 0.5)) - 1, size.y - 1);
        float z = mix(za, zb, t);
        float cov = mix(ca, cb, t);
        for (int yy = y0; yy <= y1; ++yy) {
            ivec2 q = steep ? ivec2(yy, x) : ivec2(x, yy);
            RASTER_VISIT(q, z, cov);
        }
    }
}
