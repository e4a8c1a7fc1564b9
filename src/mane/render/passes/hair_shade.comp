#version 430
// The compute rasteriser, step 2: per pixel, each sample's nearest segment (hair_raster.comp)
// shaded at the sample's point on it (each distinct id in a pixel shaded once), with the sample's
// coverage as alpha over what is already there (the head and background, premultiplied), the
// samples averaged into the HDR image. The buffers are reset for the next frame on the way.
#include "shading/hair_shading.glsl"
#include "hair_radiance.glsl"
#include "hair_vis.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
layout(rgba16f, binding = IMG_HDR) uniform image2D u_hdr;
uniform int u_points_per_strand;
#include "raster_view.glsl"

vec3 shade_segment(uint i, vec2 q) {
    vec4 p0 = expanded[2 * i], t0 = expanded[2 * i + 1];
    vec4 p1 = expanded[2 * i + 2], t1 = expanded[2 * i + 3];
    float t = raster_param(raster_point(p0.xyz, p0.w), raster_point(p1.xyz, p1.w), q);
    vec3 P = mix(p0.xyz, p1.xyz, t);
    vec3 T = normalize(mix(t0.xyz, t1.xyz, t));
    float j = float(i % uint(u_points_per_strand));
    return hair_radiance(P, T, u_eye, (j + t) / float(u_points_per_strand - 1), t0.w);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = u_raster_size / u_grid;
    if (p.x >= size.x || p.y >= size.y) return;
    vec4 bg = imageLoad(u_hdr, p);
    vec4 sum = vec4(0.0);
    // a pixel's distinct segments are shaded once each (up to MAX_SHADED, then by sample)
    const int MAX_SHADED = 4;
    uint shaded_id[MAX_SHADED];
    vec3 shaded[MAX_SHADED];
    int n_shaded = 0;
    for (int sy = 0; sy < u_grid; ++sy)
        for (int sx = 0; sx < u_grid; ++sx) {
            ivec2 q = p * u_grid + ivec2(sx, sy);
            uint idx = sample_index(q, size.x, u_grid);
#if VIS64
            uint id = uint(vis[idx] & 0xFFFFFFFFul);
            vis[idx] = ~0ul;
#else
            uint id = vis_id[idx] - 1u;   // 0 (none) -> VIS_EMPTY
            vis_depth[idx] = VIS_EMPTY;
            vis_id[idx] = 0u;
#endif
            uint units = cover[idx];
            cover[idx] = 0u;
            if (id == VIS_EMPTY) { sum += bg; continue; }
            vec3 color = vec3(-1.0);
            for (int k = 0; k < n_shaded; ++k)
                if (shaded_id[k] == id) color = shaded[k];
            if (color.r < 0.0) {
                color = shade_segment(id, vec2(q) + 0.5);
                if (n_shaded < MAX_SHADED) {
                    shaded_id[n_shaded] = id;
                    shaded[n_shaded] = color;
                    ++n_shaded;
                }
            }
            float a = cover_alpha(units);
            sum += vec4(color * a, a) + bg * (1.0 - a);
        }
    imageStore(u_hdr, p, sum / float(u_grid * u_grid));
}
