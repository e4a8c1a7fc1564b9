// The hair's coverage under MSAA as a sample mask (the raster-unit path). A strand of coverage
// alpha a (true width / drawn width, passes/hair_pull.vert) covers each of the pixel's samples
// with probability a, drawn independently per strand and per pixel: round(a * N) samples by
// stochastic rounding (a hashed threshold), placed by a hashed rotation of the sample indices.
// Fixed alpha to coverage gives every strand of equal alpha the same samples, so overlapping
// thin strands hide each other's coverage (0.55-0.63x the compute rasteriser's on Sintel); here
// a sample stays uncovered by strands 1..k with probability prod(1 - a_i), exactly the compute
// rasteriser's 1 - exp(-sum(-log(1 - a_i))) (hair_vis.glsl). The same strand, pixel and alpha
// give the same mask in the depth pre-pass and the shading pass.
uint coverage_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

int coverage_mask(float alpha, int strand, ivec2 pixel) {
    int n = gl_NumSamples;
    if (n <= 1) return alpha > 0.0 ? -1 : 0;   // single-sampled targets: blending does the rest
    uint hs = coverage_hash(uint(strand) + 0x9E3779B9u);
    uint h = coverage_hash(hs ^ coverage_hash(uint(pixel.x) + coverage_hash(uint(pixel.y))));
    // the rounding threshold: a 4x4 Bayer matrix shifted by the strand's own random, so that
    // along a strand the covered samples are spread evenly (not in random clusters), while
    // each strand's threshold at a pixel is still uniform and independent of the others'
    ivec2 b = pixel & 3;
    int bayer = (((b.x ^ b.y) & 1) << 3) | ((b.y & 1) << 2) | (((b.x ^ b.y) & 2) << 0) | ((b.y & 2) >> 1);
    float u = fract((float(bayer) + 0.5) / 16.0 + float(hs >> 8) * (1.0 / 16777216.0));
    int k = clamp(int(floor(clamp(alpha, 0.0, 1.0) * float(n) + u)), 0, n);
    int full = (1 << n) - 1;
    int run = (1 << k) - 1;
    int r = int(coverage_hash(h) % uint(n));
    return ((run << r) | (run >> (n - r))) & full;
}
