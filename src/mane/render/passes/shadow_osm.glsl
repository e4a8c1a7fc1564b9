// Opacity shadow maps (Kim and Neumann 2001; Hunz §4): 4 * u_osm_targets uniform slices between
// the hair's nearest and farthest light depth (u_osm_range); slice i's opacity (not cumulative)
// sits in channel i % 4 of target i / 4. At a depth z the opacity in front is the prefix sum of
// the slices before z plus the part of z's own slice in front of it (linear inside a slice),
// T = exp(-u_shadow_density * O). PCF on T.
#if SHADOWS == 4
#define OSM_MAX_TARGETS 8
uniform sampler2D u_osm[OSM_MAX_TARGETS];
uniform int u_osm_targets;
uniform vec2 u_osm_range;      // light depth of the first slice's front and the last slice's back (m)

float osm_opacity(ivec2 t, float z) {
    float x = (z - u_osm_range.x) / max(u_osm_range.y - u_osm_range.x, 1e-6) * float(4 * u_osm_targets);
    if (x <= 0.0) return 0.0;
    float O = 0.0;
    for (int k = 0; k < OSM_MAX_TARGETS; ++k) {
        if (k >= u_osm_targets) break;
        vec4 o = texelFetch(u_osm[k], t, 0);
        vec4 w = clamp(vec4(x) - (vec4(4 * k) + vec4(0.0, 1.0, 2.0, 3.0)), 0.0, 1.0);
        O += dot(o, w);
    }
    return O;
}

float osm_transmittance(vec3 P) {
    vec3 q = light_uvz(P);
    ivec2 size = textureSize(u_osm[0], 0);
    float tr;
    PCF_BILINEAR(tr, q.xy * vec2(size) - 0.5, size, t, exp(-u_shadow_density * osm_opacity(t, q.z - u_shadow_bias)))
    return tr;
}
#endif
