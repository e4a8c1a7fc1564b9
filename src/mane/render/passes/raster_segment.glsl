// Scan conversion of strand segments in a compute shader (the compute rasteriser: hair drawn
// without the GPU's raster units, as Unreal's and Frostbite's strand rasterisers do).
//
//     #define RASTER_VISIT(Q, Z, COV) ...   // before the include: what to do at sample Q
//     #include "raster_segment.glsl"
//     void main() { raster_expanded_segment(); }
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
//
// raster_span() sets a segment up (steep segments swap x and y, every segment walks left to
// right, its columns x0..x1 clamped); raster_column() visits the samples of one column. Both
// forms of raster_expanded_segment (below) call these two, so they visit the same samples with
// the same z and coverage.
//
//     #define RASTER_CULL(Q0, Q1, Z) ...   // optional: true skips the samples of a box
//     #define RASTER_CULLED(N) ...         // optional: told how many samples a cull skipped
//
// Culling (hair_raster.comp and oit_raster.comp: what lies behind the head's depth tile map,
// depth_tiles.glsl): a kernel that defines RASTER_CULL is asked whether every sample of the box
// Q0..Q1 (inclusive, samples, not swapped) would be rejected at a depth of at least Z, once per
// segment (its bounding box and its smallest depth; raster_span_box) and, for a segment it
// keeps, once per column (along which z and coverage are constant); RASTER_VISIT is not called
// on what it skips. RASTER_CULLED(N), where defined, counts the samples skipped (for a segment,
// walking its columns: statistics only).
//
//     #define RASTER_KEEP_SPAN(S) ...      // optional: false leaves span S to another dispatch
//
// (hair_raster.comp splits the segments by depth between two dispatches: occlusion_tiles.py.)
#ifndef RASTER_CULL_SPANS
#define RASTER_CULL_SPANS 1     // RASTER_CULL asked per segment (0: not; depth_tiles.py's A/B parts)
#endif
#ifndef RASTER_CULL_COLUMNS
#define RASTER_CULL_COLUMNS 1   // and per column
#endif
#ifndef RASTER_MAX_STEPS
#define RASTER_MAX_STEPS 8192
#endif
#ifndef RASTER_MAX_SPAN
#define RASTER_MAX_SPAN 64
#endif

struct RasterSpan {
    vec2 a, d;             // the first end and b - a, major axis along x (swapped when steep)
    float za, zb, ha, hb, ca, cb;
    float inv_cos;         // length(d) / d.x: a column's band across is 2h x inv_cos
    bool steep;            // x and y swapped
    int x0, x1;            // the sample columns (x1 < x0: none)
};

RasterSpan raster_span(vec2 a, vec2 b, float za, float zb, float ha, float hb, float ca, float cb, ivec2 size) {
    RasterSpan s;
    vec2 d = b - a;
    s.steep = abs(d.y) > abs(d.x);
    if (s.steep) { a = a.yx; b = b.yx; d = d.yx; size = size.yx; }
    if (d.x < 0.0) {   // walk left to right
        vec2 tv = a; a = b; b = tv; d = -d;
        float t = za; za = zb; zb = t;
        t = ha; ha = hb; hb = t;
        t = ca; ca = cb; cb = t;
    }
    s.a = a; s.d = d; s.za = za; s.zb = zb; s.ha = ha; s.hb = hb; s.ca = ca; s.cb = cb;
    s.inv_cos = 1.0;
    s.x0 = 0;
    s.x1 = -1;
    if (!(d.x > 1e-6)) return s;   // shorter than a sample along its major axis (or NaN)
    s.inv_cos = length(d) / d.x;
    s.x0 = max(int(ceil(a.x - 0.5)), 0);
    s.x1 = min(min(int(ceil(b.x - 0.5)) - 1, size.x - 1), s.x0 + RASTER_MAX_STEPS);
    return s;
}

// the number of columns of a span (0..RASTER_MAX_STEPS + 1)
int raster_columns(RasterSpan s) {
    return s.x1 >= s.x0 ? s.x1 - s.x0 + 1 : 0;
}

// column x's samples y0..y1 along the minor axis (swapped when steep; none when y1 < y0), its
// depth and its coverage (x0 <= x <= x1); size: the sample grid (not swapped)
void raster_column_range(RasterSpan s, int x, ivec2 size, out int y0, out int y1, out float z, out float cov) {
    int ny = s.steep ? size.x : size.y;
    float t = (float(x) + 0.5 - s.a.x) / s.d.x;
    float y = s.a.y + t * s.d.y;
    float h = min(mix(s.ha, s.hb, t) * s.inv_cos, float(RASTER_MAX_SPAN));
    y0 = max(int(ceil(y - h - 0.5)), 0);
    y1 = min(int(ceil(y + h - 0.5)) - 1, ny - 1);
    z = mix(s.za, s.zb, t);
    cov = mix(s.ca, s.cb, t);
}

// the samples of column x (x0 <= x <= x1) of span s; size: the sample grid (not swapped)
void raster_column(RasterSpan s, int x, ivec2 size) {
    int y0, y1;
    float z, cov;
    raster_column_range(s, x, size, y0, y1, z, cov);
#if defined(RASTER_CULL) && RASTER_CULL_COLUMNS
    if (y0 <= y1) {
        ivec2 q0 = s.steep ? ivec2(y0, x) : ivec2(x, y0);
        ivec2 q1 = s.steep ? ivec2(y1, x) : ivec2(x, y1);
        if (RASTER_CULL(q0, q1, z)) {
#ifdef RASTER_CULLED
            RASTER_CULLED(y1 - y0 + 1);
#endif
            return;
        }
    }
#endif
    for (int yy = y0; yy <= y1; ++yy) {
        ivec2 q = s.steep ? ivec2(yy, x) : ivec2(x, yy);
        RASTER_VISIT(q, z, cov);
    }
}

#ifdef RASTER_CULL
// A box of samples (not swapped) holding every sample of span s's columns, a sample's margin
// around the end points' rows widened by the larger half width (t lies in [0, 1) at every
// column), and a depth at or below every column's (mix() may round below its ends, as an fma
// by up to an ulp of |zb - za|: a margin of 1e-6 (1 + |za| + |zb|), 16 steps of a 24-bit depth
// buffer at the usual window depths); false: no samples, a NaN, or an end past 2^20 samples
// from the origin (an end near the eye's plane: there a column's y, a sum of large terms, may
// round by more than the margin).
bool raster_span_box(RasterSpan s, ivec2 size, out ivec2 q0, out ivec2 q1, out float zmin) {
    q0 = ivec2(0);
    q1 = ivec2(-1);
    zmin = min(s.za, s.zb) - 1e-6 * (1.0 + abs(s.za) + abs(s.zb));
    int ny = s.steep ? size.x : size.y;
    float h = min(max(s.ha, s.hb) * s.inv_cos, float(RASTER_MAX_SPAN));
    float ya = s.a.y, yb = s.a.y + s.d.y;
    float lo = min(ya, yb) - h - 1.5, hi = max(ya, yb) + h + 0.5;
    vec2 b = s.a + s.d;
    if (s.x1 < s.x0 || !(lo <= hi) || !(zmin == zmin)
        || !(max(max(abs(s.a.x), abs(s.a.y)), max(abs(b.x), abs(b.y))) <= 1048576.0)) return false;
    int y0 = int(clamp(floor(lo), 0.0, float(ny)));
    int y1 = int(clamp(ceil(hi), -1.0, float(ny - 1)));
    if (y1 < y0) return false;
    q0 = s.steep ? ivec2(y0, s.x0) : ivec2(s.x0, y0);
    q1 = s.steep ? ivec2(y1, s.x1) : ivec2(s.x1, y1);
    return true;
}

// whether the kernel skips span s whole (RASTER_CULL on its box)
bool raster_span_culled(RasterSpan s, ivec2 size) {
    ivec2 q0, q1;
    float zmin;
    if (!raster_span_box(s, size, q0, q1, zmin) || !RASTER_CULL(q0, q1, zmin)) return false;
#ifdef RASTER_CULLED
    for (int x = s.x0; x <= s.x1; ++x) {   // the samples it would have visited
        int y0, y1;
        float z, cov;
        raster_column_range(s, x, size, y0, y1, z, cov);
        RASTER_CULLED(max(y1 - y0 + 1, 0));
    }
#endif
    return true;
}
#endif

// The segments of the expanded strands (strand_expand.comp: strands of u_points_per_strand
// points, 2 vec4 a point), the loop of every compute-raster kernel (hair_raster.comp,
// dom_raster.comp, oit/oit_raster.comp), one invocation per segment. Before the include: the
// `expanded` buffer, u_points_per_strand, u_num_segments and raster_view.glsl;
// RASTER_DEPTH, the RasterPoint field handed to RASTER_VISIT as Z (window_z, the default, or
// depth in metres); RASTER_SEGMENT(I), run with a segment's first point before its samples are
// visited (per column in the balanced form: the state it sets is the visit's segment's).
//
// RASTER_BALANCE (raster_segment.py: 1 on GPUs, 0 on CPU rasterisers): 0, the invocation
// walks its own segment's columns (in close-ups a segment crosses tens to hundreds of columns,
// so a warp waits on its longest segment); 1, the
// work group (local_size_x, every thread calling this, none returning before it) sets up its
// segments, stores them and their column counts in shared memory, prefix-sums the counts and
// deals the group's columns round-robin to its threads (each finds its column's segment by
// binary search). Atomic min and integer add commute, so the buffers end bit-identical; 2, the
// tiled form (hair_raster.comp only: raster_tiles.glsl brings its own loops, calling
// raster_thread_span, raster_span and raster_column_range).
#ifndef RASTER_DEPTH
#define RASTER_DEPTH window_z
#endif
#ifndef RASTER_SEGMENT
#define RASTER_SEGMENT(I)
#endif
#ifndef RASTER_STRAND
#define RASTER_STRAND(S) (S)   // the expanded strand of the dispatch's strand S (dom_raster.comp: a stride)
#endif
#ifndef RASTER_BALANCE
#error "RASTER_BALANCE must be defined (raster_segment.py)"
#endif

// The thread's segment: false when none (past the end, a strand the distance LOD dropped, an
// end behind the eye); i: its first point.
bool raster_thread_span(out RasterSpan s, out int i) {
    s.x0 = 0;
    s.x1 = -1;
    i = 0;
    int k = int((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x
                + gl_LocalInvocationID.x);
    if (k >= u_num_segments) return false;
    int per = u_points_per_strand - 1;
    int strand = k / per;
    i = RASTER_STRAND(strand) * u_points_per_strand + (k - strand * per);
    vec4 p0 = expanded[2 * i];
    vec4 p1 = expanded[2 * i + 2];
    if (!(p0.w > 0.0 || p1.w > 0.0)) return false;   // a strand the distance LOD dropped
    RasterPoint a = raster_point(p0.xyz, p0.w);
    RasterPoint b = raster_point(p1.xyz, p1.w);
    if (!a.ok || !b.ok) return false;   // behind the eye
    s = raster_span(a.s, b.s, a.RASTER_DEPTH, b.RASTER_DEPTH, a.half_width, b.half_width, a.coverage, b.coverage,
                    u_raster_size);
#ifdef RASTER_KEEP_SPAN
    if (!RASTER_KEEP_SPAN(s)) {   // left to another dispatch (hair_raster.comp's depth split)
        s.x1 = s.x0 - 1;
        return false;
    }
#endif
#if defined(RASTER_CULL) && RASTER_CULL_SPANS
    if (raster_span_culled(s, u_raster_size)) {   // none of its columns
        s.x1 = s.x0 - 1;
        return false;
    }
#endif
    return true;
}

// What the balanced and tiled forms keep of a span in shared memory, 13 words: ad (a, d), zh
// (za, zb, ha, hb), ci (ca, cb, inv_cos as bits; the first point i) and xs (the first column
// x0 >= 0 | steep << 31). A vec3 and an ivec3 array had taken 16 words a span: a work group's
// shared memory bounds how many share an SM (H200: the tiled close-up's raster 2.97 -> 2.50 ms,
// the target frame's balanced raster 0.53 -> 0.48 ms).
uvec4 raster_span_ci(RasterSpan s, int i) {
    return uvec4(floatBitsToUint(vec3(s.ca, s.cb, s.inv_cos)), uint(i));
}

int raster_span_xs(RasterSpan s, int x0) {
    return x0 | (s.steep ? int(0x80000000) : 0);
}

// the span back from those words and its column count
RasterSpan raster_span_unpacked(vec4 ad, vec4 zh, uvec4 ci, int xs, int columns) {
    RasterSpan t;
    t.a = ad.xy; t.d = ad.zw;
    t.za = zh.x; t.zb = zh.y; t.ha = zh.z; t.hb = zh.w;
    vec3 c = uintBitsToFloat(ci.xyz);
    t.ca = c.x; t.cb = c.y; t.inv_cos = c.z;
    t.steep = xs < 0;
    t.x0 = xs & 0x7FFFFFFF;
    t.x1 = t.x0 + columns - 1;
    return t;
}

#if RASTER_BALANCE == 1
#define RASTER_GROUP int(gl_WorkGroupSize.x)
shared vec4 rs_ad[gl_WorkGroupSize.x];      // a, d
shared vec4 rs_zh[gl_WorkGroupSize.x];      // za, zb, ha, hb
shared uvec4 rs_ci[gl_WorkGroupSize.x];     // ca, cb, inv_cos (bits), first point
shared int rs_xs[gl_WorkGroupSize.x];       // x0 | steep << 31
#ifndef RASTER_SUBGROUP
#define RASTER_SUBGROUP 0
#endif
#if RASTER_SUBGROUP
// the column counts' prefix sum by subgroups (GL_KHR_shader_subgroup_arithmetic, declared by the
// including kernel; subgroups of consecutive invocations of >= 8: raster_segment.subgroup_scan),
// then each subgroup's total in front: two barriers where Hillis-Steele takes log2(group) + 1
shared int rs_scan[gl_WorkGroupSize.x];
shared int rs_wsum[gl_WorkGroupSize.x / 8u];
#else
shared int rs_scan[2u * gl_WorkGroupSize.x];   // the column counts' prefix sum, two halves in turn
#endif

void raster_expanded_segment() {
    RasterSpan s;
    int i;
    raster_thread_span(s, i);
    int lid = int(gl_LocalInvocationID.x);
    rs_ad[lid] = vec4(s.a, s.d);
    rs_zh[lid] = vec4(s.za, s.zb, s.ha, s.hb);
    rs_ci[lid] = raster_span_ci(s, i);
    rs_xs[lid] = raster_span_xs(s, s.x0);
#if RASTER_SUBGROUP
    int incl = subgroupInclusiveAdd(raster_columns(s));
    if (gl_SubgroupInvocationID == gl_SubgroupSize - 1u) rs_wsum[gl_SubgroupID] = incl;
    barrier();
    for (uint w = 0u; w < gl_SubgroupID; ++w) incl += rs_wsum[w];
    rs_scan[lid] = incl;
    barrier();
    int src = 0;
#else
    rs_scan[lid] = raster_columns(s);
    barrier();
    int src = 0;   // Hillis-Steele inclusive scan, reading one half and writing the other
    for (int off = 1; off < RASTER_GROUP; off <<= 1) {
        int v = rs_scan[src + lid];
        if (lid >= off) v += rs_scan[src + lid - off];
        src = RASTER_GROUP - src;
        rs_scan[src + lid] = v;
        barrier();
    }
#endif
    // rs_scan[src + k]: the columns of segments 0..k; column j of the group is column
    // j - (end of k - 1) of the first segment k whose end passes j
    int total = rs_scan[src + RASTER_GROUP - 1];   // <= group size x (RASTER_MAX_STEPS + 1): bounded
    int lo = 0, cur = -1, start = 0;
    RasterSpan t;
    for (int j = lid; j < total; j += RASTER_GROUP) {
        int hi = RASTER_GROUP - 1;   // j only grows: the last segment found bounds the search below
        while (lo < hi) {
            int mid = (lo + hi) >> 1;
            if (rs_scan[src + mid] > j) hi = mid; else lo = mid + 1;
        }
        if (lo != cur) {   // a new segment for this thread: its span from shared memory
            cur = lo;
            start = lo > 0 ? rs_scan[src + lo - 1] : 0;
            uvec4 ci = rs_ci[lo];
            t = raster_span_unpacked(rs_ad[lo], rs_zh[lo], ci, rs_xs[lo], rs_scan[src + lo] - start);
            RASTER_SEGMENT(int(ci.w));
        }
        raster_column(t, t.x0 + j - start, u_raster_size);
    }
}
#elif RASTER_BALANCE == 0
void raster_expanded_segment() {
    RasterSpan s;
    int i;
    if (!raster_thread_span(s, i)) return;
    RASTER_SEGMENT(i);
    for (int x = s.x0; x <= s.x1; ++x) raster_column(s, x, u_raster_size);
}
#endif
