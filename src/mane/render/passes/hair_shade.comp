#version 430
// The compute rasteriser, step 2: per pixel, each sample's nearest segment (hair_raster.comp)
// shaded at the sample's point on it (each distinct id in a pixel shaded once, at its first
// sample; past MAX_SHADED distinct ids, by sample), with the sample's coverage as alpha over
// what is already there (the head and background, premultiplied), the samples averaged into the
// HDR image. The buffers are reset for the next frame on the way.
// A work group (SHADE_GROUP_X x SHADE_GROUP_Y pixels: hair_compute.shade_group) lists its pixels'
// shading jobs in shared memory, shades the list with every thread, then each thread sums its
// samples from it: a thread a pixel shading its own 1-4 jobs left most lanes idle (H200, 1080p:
// the 100k close-up's shading 1.94 -> 1.58 ms, the 50k target frame's 1.33 -> 0.96; the same
// image; 16 x 8 pixels a group rather than 8 x 8, up to 4 samples: the close-up 3.96 -> 3.84 ms).
// A sample no segment reached is not reset (it is already empty) and a pixel with none is not
// written: those writes over the whole screen had cost the pass more than its shading (H200: the
// target frame 0.96 -> 0.20 ms, the 100k close-up 1.58 -> 0.98; the same image). SHADE_GRID: the
// samples per pixel along x and y (u_grid), a constant here for the per-thread arrays.
#include "shading/hair_shading.glsl"
#include "hair_radiance.glsl"
#include "hair_vis.glsl"
layout(local_size_x = SHADE_GROUP_X, local_size_y = SHADE_GROUP_Y) in;
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
layout(rgba16f, binding = IMG_HDR) uniform image2D u_hdr;
#if MS_SPLIT
// the multiply scattered light (hair_radiance.glsl's g_hair_ms) times each sample's coverage, and
// the coverage, averaged over the pixel's samples: ms_smooth.comp smooths it and adds it to u_hdr
layout(rgba16f, binding = IMG_MS) writeonly uniform image2D u_ms;
#endif
uniform int u_points_per_strand;
#include "raster_view.glsl"

vec3 shade_segment(uint i, vec2 q) {
    vec4 p0 = expanded[2 * i], t0 = expanded[2 * i + 1];
    vec4 p1 = expanded[2 * i + 2], t1 = expanded[2 * i + 3];
    RasterPoint a = raster_point(p0.xyz, p0.w), b = raster_point(p1.xyz, p1.w);
    float t = raster_param(a, b, q);
#if HAIR_NEAR_FIELD
    vec2 across = raster_across(a, b, (floor(q / float(u_grid)) + 0.5) * float(u_grid));   // at the pixel's centre
    hair_set_near(across.x, across.y);
#endif
    vec3 P = mix(p0.xyz, p1.xyz, t);
    vec3 T = normalize(mix(t0.xyz, t1.xyz, t));
    float j = float(i % uint(u_points_per_strand));
    return hair_radiance(P, T, u_eye, (j + t) / float(u_points_per_strand - 1), t0.w);
}

#define SAMPLES (SHADE_GRID * SHADE_GRID)
#define GROUP_PIXELS (SHADE_GROUP_X * SHADE_GROUP_Y)
#define MAX_JOBS (GROUP_PIXELS * SAMPLES)
shared uint s_job_id[MAX_JOBS];
shared uint s_job_q[MAX_JOBS];   // the sample shaded: x | y << 16
// a job's colour in half floats: r, g | b and (with MS_SPLIT) the multiply scattered light's r;
// its g, b in s_ms_gb. As vec3s the two colours' 24-32 bytes a job had cut the groups an SM holds
// (H200, the 100k close-up with the split: the pass 0.67 -> 0.88 ms)
shared uvec2 s_color[MAX_JOBS];
#if MS_SPLIT
shared uint s_ms_gb[MAX_JOBS];
#endif
shared uint s_jobs;

// With 2 x 2 samples a pixel's four words lie together (sample_index): read and reset as one
// vector each, not as four strided words (H200: the 100k close-up's pass 0.98 -> 0.80 ms, the
// target frame's 0.21 -> 0.16)
#define SHADE_VEC4 (SAMPLES == 4)
#if SHADE_VEC4
#if VIS64
layout(std430, binding = B_VIS) buffer Vis4 { u64vec4 vis4[]; };
#else
layout(std430, binding = B_VIS) buffer VisDepth4 { uvec4 vis_depth4[]; };
layout(std430, binding = B_VIS_ID) buffer VisId4 { uvec4 vis_id4[]; };
#endif
layout(std430, binding = B_COVER) buffer Cover4 { uvec4 cover4[]; };
#endif

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = u_raster_size / SHADE_GRID;
    bool inside = p.x < size.x && p.y < size.y;
    if (gl_LocalInvocationIndex == 0u) s_jobs = 0u;
    barrier();
    int job[SAMPLES];
    uint units[SAMPLES];
    bool hair = false;
    if (inside) {
        // each sample's nearest segment and coverage, and the words reset for the next frame; a
        // sample no segment reached holds no coverage either (the raster adds coverage only
        // where it also takes the depth min): nothing to reset there
        uint ids[SAMPLES];
#if SHADE_VEC4
        uint pix = uint(p.y) * uint(size.x) + uint(p.x);
#if VIS64
        uvec4 id4 = uvec4(vis4[pix] & u64vec4(0xFFFFFFFFul));
#else
        uvec4 id4 = vis_id4[pix] - 1u;   // 0 (none) -> VIS_EMPTY
#endif
        uvec4 c4 = uvec4(0u);
        hair = any(notEqual(id4, uvec4(VIS_EMPTY)));
        if (hair) {   // (an empty sample's words rewritten as they are)
#if VIS64
            vis4[pix] = u64vec4(~0ul);
#else
            vis_depth4[pix] = uvec4(VIS_EMPTY);
            vis_id4[pix] = uvec4(0u);
#endif
            c4 = cover4[pix];
            cover4[pix] = uvec4(0u);
        }
        for (int s = 0; s < 4; ++s) {
            ids[s] = id4[s];
            units[s] = c4[s];
        }
#else
        for (int s = 0; s < SAMPLES; ++s) {
            ivec2 q = p * SHADE_GRID + ivec2(s % SHADE_GRID, s / SHADE_GRID);
            uint idx = sample_index(q, size.x, SHADE_GRID);
            units[s] = 0u;
#if VIS64
            ids[s] = uint(vis[idx] & 0xFFFFFFFFul);
            if (ids[s] == VIS_EMPTY) continue;
            vis[idx] = ~0ul;
#else
            ids[s] = vis_id[idx] - 1u;
            if (ids[s] == VIS_EMPTY) continue;
            vis_depth[idx] = VIS_EMPTY;
            vis_id[idx] = 0u;
#endif
            hair = true;
            units[s] = cover[idx];
            cover[idx] = 0u;
        }
#endif
        const int MAX_SHADED = 4;
        uint shaded_id[MAX_SHADED];
        int shaded_job[MAX_SHADED];
        int n_shaded = 0;
        for (int s = 0; s < SAMPLES; ++s) {
            uint id = ids[s];
            job[s] = -1;
            if (id == VIS_EMPTY) continue;
            for (int k = 0; k < n_shaded; ++k)
                if (shaded_id[k] == id) job[s] = shaded_job[k];
            if (job[s] < 0) {
                ivec2 q = p * SHADE_GRID + ivec2(s % SHADE_GRID, s / SHADE_GRID);
                int j = int(atomicAdd(s_jobs, 1u));
                s_job_id[j] = id;
                s_job_q[j] = uint(q.x) | (uint(q.y) << 16);
                job[s] = j;
                if (n_shaded < MAX_SHADED) {
                    shaded_id[n_shaded] = id;
                    shaded_job[n_shaded] = j;
                    ++n_shaded;
                }
            }
        }
    }
    barrier();
    uint n = s_jobs;
    for (uint j = gl_LocalInvocationIndex; j < n; j += uint(GROUP_PIXELS)) {
        uint qb = s_job_q[j];
        vec3 c = shade_segment(s_job_id[j], vec2(float(qb & 0xFFFFu), float(qb >> 16)) + 0.5);
#if MS_SPLIT
        s_color[j] = uvec2(packHalf2x16(c.rg), packHalf2x16(vec2(c.b, g_hair_ms.r)));
        s_ms_gb[j] = packHalf2x16(g_hair_ms.gb);
#else
        s_color[j] = uvec2(packHalf2x16(c.rg), packHalf2x16(vec2(c.b, 0.0)));
#endif
    }
    barrier();
    if (!hair) return;   // the head and background as they are
    vec4 bg = imageLoad(u_hdr, p);
    vec4 sum = vec4(0.0);
#if MS_SPLIT
    vec4 ms = vec4(0.0);
#endif
    for (int s = 0; s < SAMPLES; ++s) {
        if (job[s] < 0) { sum += bg; continue; }
        float a = cover_alpha(units[s]);
        uvec2 c = s_color[job[s]];
        vec2 b_ms = unpackHalf2x16(c.y);
        sum += vec4(vec3(unpackHalf2x16(c.x), b_ms.x) * a, a) + bg * (1.0 - a);
#if MS_SPLIT
        ms += vec4(vec3(b_ms.y, unpackHalf2x16(s_ms_gb[job[s]])) * a, a);
#endif
    }
    imageStore(u_hdr, p, sum / float(SAMPLES));
#if MS_SPLIT
    imageStore(u_ms, p, ms / float(SAMPLES));
#endif
}
