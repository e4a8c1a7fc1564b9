#version 430
// Parallel-transported normals along every guide: the clump's disc turns with the strand.
layout(local_size_x = 64) in;
layout(std430, binding = B_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = B_FRAMES) writeonly buffer Frames { vec4 frames[]; };
uniform int u_n;
uniform int u_num_guides;

vec3 safe_dir(vec3 d, vec3 fallback) {
    float l = length(d);
    return l > 1e-12 ? d / l : fallback;
}

void main() {
    int g = int(gl_GlobalInvocationID.x);
    if (g >= u_num_guides) return;
    int base = g * u_n;
    vec3 t = safe_dir(positions[base + 1].xyz - positions[base].xyz, vec3(0.0, -1.0, 0.0));
    // a deterministic start perpendicular to the root's direction
    vec3 a = abs(t.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 n = normalize(cross(cross(t, a), t));
    frames[base] = vec4(n, 0.0);
    for (int k = 1; k < u_n; ++k) {
        int kn = min(k + 1, u_n - 1);
        vec3 t2 = safe_dir(positions[base + kn].xyz - positions[base + k - 1].xyz, t);
        // rotate n by the rotation taking t to t2 (double reflection would be exact; the
        // projection is enough for guide segments that turn by less than ~60 degrees)
        vec3 m = n - t2 * dot(n, t2);
        n = length(m) > 1e-6 ? normalize(m) : n;
        frames[base + k] = vec4(n, 0.0);
        t = t2;
    }
}
