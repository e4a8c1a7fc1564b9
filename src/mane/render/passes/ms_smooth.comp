#version 430
// passes/ms_smooth.py: the multiply scattered light (hair_shade.comp's u_ms: its radiance times
// the hair's coverage, and the coverage, per pixel) smoothed across the hair by a Gaussian of
// u_sigma pixels, rows then columns. DIRECTION 0: u_ms's rows into u_rows (every pixel: the
// columns read them); 1: u_rows' columns, then, where the pixel has hair, u_hdr gains the smoothed
// radiance per unit of coverage times the pixel's own coverage. The weights need no
// normalisation: the coverage is smoothed with them.
layout(local_size_x = 8, local_size_y = 8) in;
#if DIRECTION == 0
layout(rgba16f, binding = IMG_MS) readonly uniform image2D u_src;
layout(rgba16f, binding = IMG_MS_ROWS) writeonly uniform image2D u_dst;
#else
layout(rgba16f, binding = IMG_MS_ROWS) readonly uniform image2D u_src;
layout(rgba16f, binding = IMG_MS) readonly uniform image2D u_own;
layout(rgba16f, binding = IMG_HDR) uniform image2D u_hdr;
#endif
uniform int u_radius;     // taps each side
uniform float u_sigma;    // pixels

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_src);
    if (p.x >= size.x || p.y >= size.y) return;
#if DIRECTION == 1
    vec4 own = imageLoad(u_own, p);
    if (own.a <= 0.0) return;
#endif
    ivec2 axis = DIRECTION == 0 ? ivec2(1, 0) : ivec2(0, 1);
    float k = -0.5 / (u_sigma * u_sigma);
    vec4 sum = vec4(0.0);
    for (int i = -u_radius; i <= u_radius; ++i) {
        ivec2 q = p + axis * i;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        sum += exp(k * float(i * i)) * imageLoad(u_src, q);
    }
#if DIRECTION == 0
    imageStore(u_dst, p, sum);
#else
    vec4 hdr = imageLoad(u_hdr, p);
    imageStore(u_hdr, p, vec4(hdr.rgb + sum.rgb / max(sum.a, 1e-6) * own.a, hdr.a));
#endif
}
