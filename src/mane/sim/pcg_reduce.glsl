// Workgroup reduction of (sum, max) into partials[workgroup]; every invocation must call it.
layout(std430, binding = B_PARTIALS) buffer Partials { dvec2 partials[]; };   // (sum, max) per workgroup
shared double s_sum[256];
shared double s_max[256];

void workgroup_reduce(double sum_value, double max_value) {
    uint t = gl_LocalInvocationID.x;
    s_sum[t] = sum_value;
    s_max[t] = max_value;
    barrier();
    for (uint s = 128u; s > 0u; s >>= 1) {
        if (t < s) {
            s_sum[t] += s_sum[t + s];
            s_max[t] = max(s_max[t], s_max[t + s]);
        }
        barrier();
    }
    if (t == 0u) partials[gl_WorkGroupID.x] = dvec2(s_sum[0], s_max[0]);
}
