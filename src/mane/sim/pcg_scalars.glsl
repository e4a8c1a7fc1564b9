// PCG scalars, kept on the GPU so the iteration never waits for the CPU.
layout(std430, binding = B_SCALARS) buffer Scalars {
    double pcg_sigma;    // r . z
    double pcg_alpha;
    double pcg_beta;
    double pcg_rmax;     // max |r| after the latest update
    double pcg_bmax;     // max |b|
    double pcg_dq;       // d . A d
    double pcg_pad0;
    double pcg_pad1;
};
