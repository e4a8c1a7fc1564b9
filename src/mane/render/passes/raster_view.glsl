// The compute rasteriser's view: where a strand point lands in the sample grid, its depths
// and its width there (the camera's or a light's view; set_view() sets the uniforms).
uniform mat4 u_view_proj;
uniform vec3 u_eye;           // perspective views: the eye
uniform vec3 u_view_dir;      // unit forward of the view
uniform int u_ortho;          // 1: orthographic
uniform float u_pixel_size;   // world size of a pixel at unit depth (perspective) or anywhere (ortho)
uniform float u_min_pixel_width;   // > 0: strands narrower than a sample widen to one, coverage < 1
uniform ivec2 u_raster_size;  // the sample grid (pixels x u_grid)
uniform int u_grid;           // samples per pixel along x and y
uniform int u_lines;          // 1: GL_LINES-like, one pixel wide whatever the strand's width, opaque

struct RasterPoint {
    vec2 s;            // sample units
    float window_z;    // 0 near .. 1 far (the depth buffer's value)
    float depth;       // metres along u_view_dir
    float inv_w;       // 1 / clip w (perspective-correct interpolation)
    float half_width;  // samples
    float coverage;    // 0..1: the true width over the drawn one
    bool ok;           // in front of the eye
};

RasterPoint raster_point(vec3 P, float width) {
    RasterPoint r;
    vec4 c = u_view_proj * vec4(P, 1.0);
    r.ok = c.w > 1e-6;
    float w = r.ok ? c.w : 1.0;
    vec3 ndc = c.xyz / w;
    r.s = (ndc.xy * 0.5 + 0.5) * vec2(u_raster_size);
    r.window_z = ndc.z * 0.5 + 0.5;
    r.depth = dot(P - u_eye, u_view_dir);
    r.inv_w = 1.0 / w;
    float pixel = u_ortho != 0 ? u_pixel_size : u_pixel_size * max(r.depth, 1e-4);
    float ws = width / pixel * float(u_grid);
    float wmin = u_min_pixel_width > 0.0 ? 1.0 : 0.0;
    r.coverage = ws < wmin ? ws / wmin : 1.0;
    r.half_width = 0.5 * max(ws, wmin);
    if (u_lines != 0) {
        r.coverage = 1.0;
        r.half_width = 0.5 * float(u_grid);
    }
    return r;
}

// The world parameter (0 at a, 1 at b) of sample centre q's nearest point on segment a-b on
// screen, perspective-correct (1 / w is affine in screen space).
float raster_param(RasterPoint a, RasterPoint b, vec2 q) {
    vec2 d = b.s - a.s;
    float ts = clamp(dot(q - a.s, d) / max(dot(d, d), 1e-12), 0.0, 1.0);
    float ib = ts * b.inv_w;
    return ib / max((1.0 - ts) * a.inv_w + ib, 1e-20);
}

// The near field's inputs (hair_shading.glsl's hair_set_near) at q (sample units; the pixel's
// centre) on segment a-b: (h, the strand's true width in pixels), h the signed offset from the
// segment's axis on screen
// over its drawn half width, along the screen image of cross(T, V) (the hardware ribbon's
// g_across: with x right, y up and V out of the screen, cross(T, V) is T's image turned
// clockwise), interpolated at the screen parameter as hair.geom's varyings are.
vec2 raster_across(RasterPoint a, RasterPoint b, vec2 q) {
    vec2 d = b.s - a.s;
    float len2 = dot(d, d);
    float ts = clamp(dot(q - a.s, d) / max(len2, 1e-12), 0.0, 1.0);
    vec2 r = q - a.s;
    float h = (r.x * d.y - r.y * d.x) * inversesqrt(max(len2, 1e-12)) / max(mix(a.half_width, b.half_width, ts), 1e-6);
    float width_px = 2.0 * mix(a.half_width * a.coverage, b.half_width * b.coverage, ts) / float(u_grid);
    return vec2(h, width_px);
}
