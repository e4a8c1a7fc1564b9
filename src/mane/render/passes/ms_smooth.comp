#version 430
// passes/ms_smooth.py: the multiply scattered light (hair_shade.comp's u_ms: its radiance times
// the hair's coverage, and the coverage, per pixel) smoothed across the hair by a Gaussian, on a
// grid reduced FACTOR x FACTOR. STAGE 0: u_ms summed over each cell of FACTOR x FACTOR pixels;
// 1: the cells smoothed along rows (u_sigma cells); 2: along columns; 3: where a pixel has hair,
// u_hdr gains the cells' smoothed radiance per unit of coverage, interpolated bilinearly at the
// pixel's centre, times the pixel's own coverage, and u_ms is cleared there (the shading writes
// only the pixels with hair). No weight needs normalising: the coverage is summed and smoothed
// with the radiance. (Summing the cells inside the row pass, one dispatch fewer, cost the H200
// more: each cell summed once a tap, 0.06 -> 0.16 ms at the 100k close-up.)
layout(local_size_x = 8, local_size_y = 8) in;
#if STAGE == 0
layout(rgba16f, binding = IMG_MS) readonly uniform image2D u_ms;
layout(rgba32f, binding = IMG_MS_DST) writeonly uniform image2D u_dst;
#elif STAGE == 3
layout(rgba16f, binding = IMG_MS) uniform image2D u_ms;
layout(rgba32f, binding = IMG_MS_SRC) readonly uniform image2D u_src;
layout(rgba16f, binding = IMG_HDR) uniform image2D u_hdr;
#else
layout(rgba32f, binding = IMG_MS_SRC) readonly uniform image2D u_src;
layout(rgba32f, binding = IMG_MS_DST) writeonly uniform image2D u_dst;
#endif
uniform int u_radius;     // taps each side
uniform float u_sigma;    // cells

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
#if STAGE == 0
    ivec2 size = imageSize(u_dst), full = imageSize(u_ms);
    if (p.x >= size.x || p.y >= size.y) return;
    vec4 sum = vec4(0.0);
    for (int y = 0; y < FACTOR; ++y)
        for (int x = 0; x < FACTOR; ++x) {
            ivec2 q = p * FACTOR + ivec2(x, y);
            if (q.x < full.x && q.y < full.y) sum += imageLoad(u_ms, q);
        }
    imageStore(u_dst, p, sum);
#elif STAGE == 3
    ivec2 full = imageSize(u_ms), size = imageSize(u_src);
    if (p.x >= full.x || p.y >= full.y) return;
    vec4 own = imageLoad(u_ms, p);
    if (own.a <= 0.0) return;
    vec2 u = (vec2(p) + 0.5) / float(FACTOR) - 0.5;
    ivec2 i0 = ivec2(floor(u));
    vec2 f = u - vec2(i0);
    ivec2 a = clamp(i0, ivec2(0), size - 1), b = clamp(i0 + 1, ivec2(0), size - 1);
    vec4 sum = mix(mix(imageLoad(u_src, a), imageLoad(u_src, ivec2(b.x, a.y)), f.x),
                   mix(imageLoad(u_src, ivec2(a.x, b.y)), imageLoad(u_src, b), f.x), f.y);
    vec4 hdr = imageLoad(u_hdr, p);
    imageStore(u_hdr, p, vec4(hdr.rgb + sum.rgb / max(sum.a, 1e-6) * own.a, hdr.a));
    imageStore(u_ms, p, vec4(0.0));
#else
    ivec2 size = imageSize(u_src);
    if (p.x >= size.x || p.y >= size.y) return;
    ivec2 axis = STAGE == 1 ? ivec2(1, 0) : ivec2(0, 1);
    float k = -0.5 / (u_sigma * u_sigma);
    vec4 sum = vec4(0.0);
    for (int i = -u_radius; i <= u_radius; ++i) {
        ivec2 q = p + axis * i;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        sum += exp(k * float(i * i)) * imageLoad(u_src, q);
    }
    imageStore(u_dst, p, sum);
#endif
}
