#version 430
// Bitonic sort of (key, value) pairs, ascending by key then value, n a power of two >= 512.
// LOCAL 0: one compare-exchange step (u_k, u_j) over the whole array (j >= 512).
// LOCAL 1: in shared memory, a block of 512: u_k == 0 runs every stage k = 2..512; otherwise
//          the steps j = 256..1 of stage u_k.
layout(local_size_x = 256) in;
layout(std430, binding = B_SORT_KEYS) buffer SortKeys { uvec2 keys[]; };
uniform uint u_k;
uniform uint u_j;

bool greater(uvec2 a, uvec2 b) { return a.x > b.x || (a.x == b.x && a.y > b.y); }

#if LOCAL
shared uvec2 s_keys[512];
void step_local(uint base, uint t, uint k, uint j) {
    uint i = 2u * j * (t / j) + (t % j);        // the lower index of this thread's pair
    uint l = i + j;
    bool asc = ((base + i) & k) == 0u;
    uvec2 a = s_keys[i], b = s_keys[l];
    if (greater(a, b) == asc) {
        s_keys[i] = b;
        s_keys[l] = a;
    }
}
void main() {
    uint base = gl_WorkGroupID.x * 512u;
    uint t = gl_LocalInvocationID.x;
    s_keys[t] = keys[base + t];
    s_keys[t + 256u] = keys[base + t + 256u];
    barrier();
    if (u_k == 0u) {
        for (uint k = 2u; k <= 512u; k <<= 1) {
            for (uint j = k >> 1; j > 0u; j >>= 1) {
                step_local(base, t, k, j);
                barrier();
            }
        }
    } else {
        for (uint j = 256u; j > 0u; j >>= 1) {
            step_local(base, t, u_k, j);
            barrier();
        }
    }
    keys[base + t] = s_keys[t];
    keys[base + t + 256u] = s_keys[t + 256u];
}
#else
void main() {
    uint t = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256u;
    uint i = 2u * u_j * (t / u_j) + (t % u_j);
    uint l = i + u_j;
    if (l >= uint(keys.length())) return;
    bool asc = (i & u_k) == 0u;
    uvec2 a = keys[i], b = keys[l];
    if (greater(a, b) == asc) {
        keys[i] = b;
        keys[l] = a;
    }
}
#endif
