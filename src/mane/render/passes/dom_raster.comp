#version 430
// Deep opacity maps by the compute rasteriser (deep_opacity.py, rasterizer "compute"): every
// segment of the expanded strands scan-converted into the light's map (raster_segment.glsl).
// DOM_PASS 0: z0, the nearest light depth (m) per texel, by atomic min of its bits (depths
// are > 0: the light's eye is outside the scene; read first: the atomic only where it lowers
// z0, since atomics run at the L2's atomic rate). DOM_PASS 1: strand_opacity x coverage added
// (fixed point, 1/DOM_SCALE) to the fragment's own layer only, one atomic a fragment; dom_pack
// sums the layers in front of each (the map's layers are cumulative), exactly: integers.
#if RASTER_SUBGROUP   // raster_segment.glsl's column scan by subgroups (raster_segment.subgroup_defines)
#extension GL_KHR_shader_subgroup_arithmetic : require
#endif
layout(local_size_x = 128) in;
layout(std430, binding = B_EXPANDED) readonly buffer Expanded { vec4 expanded[]; };
layout(std430, binding = B_DOM_Z0) buffer DomZ0 { uint dom_z0[]; };
layout(std430, binding = B_DOM_LAYERS) buffer DomLayers { uint dom_layers[]; };   // 3 per texel
uniform int u_points_per_strand;
uniform int u_num_segments;
uniform vec3 u_dom_layers_abs;   // layer ends after z0 (m)
uniform float u_strand_opacity;
uniform int u_strand_step;       // every u_strand_step-th expanded strand (the map's LOD, deep_opacity.py)
#define RASTER_STRAND(S) ((S) * u_strand_step)
#include "raster_view.glsl"
#define DOM_SCALE 65536.0

void visit(ivec2 q, float z, float cov) {
    if (!(z > 0.0)) return;
    uint idx = uint(q.y) * uint(u_raster_size.x) + uint(q.x);
#if DOM_PASS == 0
    uint zb = floatBitsToUint(z);
    if (zb < dom_z0[idx]) atomicMin(dom_z0[idx], zb);
#else
    float dz = z - uintBitsToFloat(dom_z0[idx]);
    uint a = uint(u_strand_opacity * cov * DOM_SCALE + 0.5);
    uint layer = dz < u_dom_layers_abs.x ? 0u : (dz < u_dom_layers_abs.y ? 1u : 2u);
    atomicAdd(dom_layers[3u * idx + layer], a);
#endif
}
#define RASTER_VISIT(Q, Z, COV) visit(Q, Z, COV)
#define RASTER_DEPTH depth   // metres along the light: the layers' widths are in metres
#include "raster_segment.glsl"

void main() {
    raster_expanded_segment();
}
