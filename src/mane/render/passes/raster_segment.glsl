// Scan conversion of one strand segment in a compute shader (the compute rasteriser: hair
// drawn without the GPU's raster units, as Unreal's and Frostbite's strand rasterisers do).
//
//     #define RASTER_VISIT(Q, Z, COV) ...   // before the include: what to do at sample Q
//     #include "raster_segment.glsl"
//     void main() { raster_expanded_segment(); }   // or raster_segment(a, b, ...) directly
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

// One thread per segment of the expanded strands (strand_expand.comp: strands of
// u_points_per_strand points, 2 vec4 a point), the loop of every compute-raster kernel
// (hair_raster.comp, dom_raster.comp, oit/oit_raster.comp). Before the include: the
// `expanded` buffer, u_points_per_strand, u_num_segments and raster_view.glsl;
// RASTER_DEPTH, the RasterPoint field handed to RASTER_VISIT as Z (window_z, the default, or
// depth in metres); RASTER_SEGMENT(I), run with the segment's first point once both ends are in
// front of the eye. False: no segment for this thread (past the end, a strand the distance LOD
// dropped, behind the eye).
#ifndef RASTER_DEPTH
#define RASTER_DEPTH window_z
#endif
#ifndef RASTER_SEGMENT
#define RASTER_SEGMENT(I)
#endif

bool raster_expanded_segment() {
    int k = int((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
                + gl_LocalInvocationID.x);
    if (k >= u_num_segments) return false;
    int per = u_points_per_strand - 1;
    int strand = k / per;
    int i = strand * u_points_per_strand + (k - strand * per);   // the segment's first point
    vec4 p0 = expanded[2 * i];
    vec4 p1 = expanded[2 * i + 2];
    if (!(p0.w > 0.0 || p1.w > 0.0)) return false;   // a strand the distance LOD dropped
    RasterPoint a = raster_point(p0.xyz, p0.w);
    RasterPoint b = raster_point(p1.xyz, p1.w);
    if (!a.ok || !b.ok) return false;   // behind the eye
    RASTER_SEGMENT(i);
    raster_segment(a.s, b.s, a.RASTER_DEPTH, b.RASTER_DEPTH, a.half_width, b.half_width, a.coverage, b.coverage,
                   u_raster_size);
    return true;
}
