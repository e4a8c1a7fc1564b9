#version 430 core
// PCG: one workgroup sums the partials and updates the scalars (no CPU round trip).
// STAGE_INIT: sigma = r.z, bmax = rmax = max|r|. STAGE_ALPHA: alpha = sigma / (d.q).
// STAGE_BETA: beta = (r.z)_new / sigma, sigma = (r.z)_new, rmax = max|r|.
layout(local_size_x = 256) in;

layout(std430, binding = B_PARTIALS) readonly buffer Partials { dvec2 partials[]; };
#include "pcg_scalars.glsl"

uniform uint num_partials;
shared double s_sum[256];
shared double s_max[256];

void main() {
    uint t = gl_LocalInvocationID.x;
    double sum = 0.0lf, mx = 0.0lf;
    for (uint i = t; i < num_partials; i += 256u) {
        dvec2 v = partials[i];
        sum += v.x;
        mx = max(mx, v.y);
    }
    s_sum[t] = sum;
    s_max[t] = mx;
    barrier();
    for (uint s = 128u; s > 0u; s >>= 1) {
        if (t < s) {
            s_sum[t] += s_sum[t + s];
            s_max[t] = max(s_max[t], s_max[t + s]);
        }
        barrier();
    }
    if (t != 0u) return;
    sum = s_sum[0];
    mx = s_max[0];
#if STAGE_INIT
    pcg_sigma = sum;
    pcg_bmax = mx;
    pcg_rmax = mx;
    pcg_alpha = 0.0lf;
    pcg_beta = 0.0lf;
#elif STAGE_ALPHA
    pcg_dq = sum;
    pcg_alpha = (abs(sum) > 0.0lf) ? pcg_sigma / sum : 0.0lf;
#elif STAGE_BETA
    pcg_beta = (pcg_sigma > 0.0lf) ? sum / pcg_sigma : 0.0lf;
    pcg_sigma = sum;
    pcg_rmax = mx;
#endif
}
