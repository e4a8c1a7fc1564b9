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
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
// AUX_PLANES planes of width x height words, rows top first (image order): the segment id + 1
// (0: none), the strand and guide ids (0xFFFFFFFF: none), depth, angle, confidence and alpha
// (floats, 0 where no hair).
#define AUX_PLANES 7
layout(std430, binding = B_AUX_OUT) writeonly buffer AuxOut { uint aux_out[]; };
uniform int u_points_per_strand;
uniform int u_strands_per_guide;
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
    uint o = uint(size.y - 1 - p.y) * uint(size.x) + uint(p.x);
    uint plane = uint(size.x * size.y);
    aux_out[o + 6u * plane] = floatBitsToUint(alpha / float(u_grid * u_grid));
    if (best == VIS_EMPTY) {
        aux_out[o] = 0u;
        aux_out[o + plane] = VIS_EMPTY;
        aux_out[o + 2u * plane] = VIS_EMPTY;
        aux_out[o + 3u * plane] = 0u;
        aux_out[o + 4u * plane] = 0u;
        aux_out[o + 5u * plane] = 0u;
        return;
    }
    vec4 p0 = expanded[2 * best], p1 = expanded[2 * best + 2];
    RasterPoint a = raster_point(p0.xyz, p0.w);
    RasterPoint b = raster_point(p1.xyz, p1.w);
    vec2 centre = (vec2(p) + 0.5) * float(u_grid);
    float t = raster_param(a, b, centre);
    vec3 P = mix(p0.xyz, p1.xyz, t);
    float depth = dot(P - u_eye, u_view_dir);
    float conf = length(coh) / float(max(covered, 1));
    uint strand = best / uint(u_points_per_strand);
    aux_out[o] = best + 1u;
    aux_out[o + plane] = strand;
    aux_out[o + 2u * plane] = strand / uint(u_strands_per_guide);
    aux_out[o + 3u * plane] = floatBitsToUint(depth);
    aux_out[o + 4u * plane] = floatBitsToUint(screen_angle(best));
    aux_out[o + 5u * plane] = floatBitsToUint(conf);
}
