#version 430
// Sorted blending, step 1: a key per guide segment (patch): (far-to-near order key, patch).
// The key is ~(view depth bits) of the segment's midpoint, so an ascending sort puts the
// farthest first; padding entries (OIT_END, OIT_END) sort last.
layout(local_size_x = 256) in;
layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_SORT_KEYS) writeonly buffer SortKeys { uvec2 keys[]; };
uniform int u_n;             // points per guide
uniform int u_patches;       // guides x (u_n - 1)
uniform int u_padded;        // power of two >= u_patches
uniform vec3 u_eye;
uniform vec3 u_view_dir;
void main() {
    int i = int(gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256u);
    if (i >= u_padded) return;
    if (i >= u_patches) { keys[i] = uvec2(0xFFFFFFFFu); return; }
    int segs = u_n - 1;
    int g = i / segs;
    int s = i - g * segs;
    vec3 mid = 0.5 * (positions[g * u_n + s].xyz + positions[g * u_n + s + 1].xyz);
    float depth = max(dot(mid - u_eye, u_view_dir), 0.0);
    keys[i] = uvec2(~floatBitsToUint(depth), uint(i));
}
