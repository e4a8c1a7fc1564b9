#version 430
// Deep opacity maps by the compute rasteriser, last step: the counters into the RGBA32F map the
// shading reads (O1, O2, O3: cumulative, z0; z0 = FAR where no hair), and reset for the next frame.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_DOM_Z0) buffer DomZ0 { uint dom_z0[]; };
layout(std430, binding = B_DOM_LAYERS) buffer DomLayers { uint dom_layers[]; };
layout(rgba32f, binding = IMG_DOM) uniform writeonly image2D u_dom_image;
uniform int u_size;
uniform float u_far;
#define DOM_SCALE 65536.0

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= u_size || p.y >= u_size) return;
    uint idx = uint(p.y) * uint(u_size) + uint(p.x);
    uint zb = dom_z0[idx];
    float z0 = zb == 0xFFFFFFFFu ? u_far : uintBitsToFloat(zb);
    // each layer holds its own fragments (dom_raster.comp): the map's layer k is layers 0..k
    uint o1 = dom_layers[3u * idx];
    uint o2 = o1 + dom_layers[3u * idx + 1u];
    uint o3 = o2 + dom_layers[3u * idx + 2u];
    vec3 o = vec3(o1, o2, o3) / DOM_SCALE;
    imageStore(u_dom_image, p, vec4(o, z0));
    dom_z0[idx] = 0xFFFFFFFFu;
    dom_layers[3u * idx] = 0u;
    dom_layers[3u * idx + 1u] = 0u;
    dom_layers[3u * idx + 2u] = 0u;
}
