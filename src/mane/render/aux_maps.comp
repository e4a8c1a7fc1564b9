#version 430
// Ground-truth maps for data sets (mane.render.aux_maps), run between the compute rasteriser's
// two steps (after hair_raster.comp, before hair_shade.comp resets the sample buffers).
// One thread per pixel: of the pixel's grid x grid samples, the one with the nearest segment
// (smallest window depth; equal depths: the first sample in row order) gives the pixel's
// segment; at the pixel centre on that segment (perspective-correct, raster_param) its depth
// along the view direction in metres; its screen direction's angle in [0, pi) from the image's
// +x axis, counter-clockwise as seen (toward the image's top). Confidence: the coherence of the
// covered samples' directions, |mean of (cos 2a, sin 2a)| (1: all agree). Alpha: the mean over
// the samples of the hair's coverage alpha (hair_vis.glsl's cover_alpha).
#include "hair_vis.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 3) readonly buffer Expanded { vec4 expanded[]; };
layout(std430, binding = 12) writeonly buffer AuxOut { uvec4 aux_out[]; };   // id + 1, depth, angle, confidence
layout(std430, binding = 13) writeonly buffer AuxAlpha { float aux_alpha[]; };
uniform int u_points_per_strand;
#include "raster_view.glsl"

const float PI = 3.14159265358979;

float screen_angle(uint i) {
    RasterPoint a = raster_point(expanded[2 * i].xyz, expanded[2 * i].w);
    RasterPoint b = raster_point(expanded[2 * i + 2].xyz, expanded[2 * i + 2].w);
    vec2 d = b.s - a.s;
    float t = atan(d.y, d.x);
    if (t < 0.0) t += PI;
    if (t >= PI) t -= PI;
    return t;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = u_raster_size / u_grid;
    if (p.x >= size.x || p.y >= size.y) return;
    uint best = VIS_EMPTY, best_z = VIS_EMPTY;
    float alpha = 0.0;
    vec2 coh = vec2(0.0);
    int covered = 0;
    for (int sy = 0; sy < u_grid; ++sy)
        for (int sx = 0; sx < u_grid; ++sx) {
            ivec2 q = p * u_grid + ivec2(sx, sy);
            uint idx = sample_index(q, size.x, u_grid);
#if VIS64
            uint id = uint(vis[idx] & 0xFFFFFFFFul);
            uint zb = uint(vis[idx] >> 32);
#else
            uint id = vis_id[idx] - 1u;
            uint zb = vis_depth[idx];
#endif
            alpha += cover_alpha(cover[idx]);
            if (id == VIS_EMPTY) continue;
            float a = screen_angle(id);
            coh += vec2(cos(2.0 * a), sin(2.0 * a));
            covered += 1;
            if (zb < best_z) { best_z = zb; best = id; }
        }
    uint o = uint(p.y) * uint(size.x) + uint(p.x);
    aux_alpha[o] = alpha / float(u_grid * u_grid);
    if (best == VIS_EMPTY) { aux_out[o] = uvec4(0u); return; }
    vec4 p0 = expanded[2 * best], p1 = expanded[2 * best + 2];
    RasterPoint a = raster_point(p0.xyz, p0.w);
    RasterPoint b = raster_point(p1.xyz, p1.w);
    vec2 centre = (vec2(p) + 0.5) * float(u_grid);
    float t = raster_param(a, b, centre);
    vec3 P = mix(p0.xyz, p1.xyz, t);
    float depth = dot(P - u_eye, u_view_dir);
    float conf = length(coh) / float(max(covered, 1));
    aux_out[o] = uvec4(best + 1u, floatBitsToUint(depth), floatBitsToUint(screen_angle(best)), floatBitsToUint(conf));
}
