#version 430
// Opacity shadow maps: this fragment's opacity goes to the channel of its own slice
// (slice i: target i / 4, channel i % 4); additive blending sums them.
in float g_alpha;
in float g_depth;
uniform vec2 u_osm_range;          // light depth (m) of the first slice's front, the last's back
uniform float u_strand_opacity;
layout(location = 0) out vec4 frag_osm[OSM_TARGETS];

void main() {
    float x = (g_depth - u_osm_range.x) / max(u_osm_range.y - u_osm_range.x, 1e-6) * float(4 * OSM_TARGETS);
    int slice = clamp(int(floor(x)), 0, 4 * OSM_TARGETS - 1);
    vec4 one = vec4(equal(ivec4(slice % 4), ivec4(0, 1, 2, 3))) * (u_strand_opacity * g_alpha);
    for (int k = 0; k < OSM_TARGETS; ++k)
        frag_osm[k] = (k == slice / 4) ? one : vec4(0.0);
}
