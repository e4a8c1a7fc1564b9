#version 430
// The shadow map with the compute rasteriser: the hair's nearest light depth per texel
// (dom_raster.comp, pass 0: atomic min of the depth bits) merged into the map the head was
// drawn into (R32F, linear light depth in m), and the counters reset for the next frame.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_DOM_Z0) buffer DomZ0 { uint dom_z0[]; };
layout(r32f, binding = IMG_SHADOW) uniform image2D u_shadow_image;
uniform int u_size;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= u_size || p.y >= u_size) return;
    uint idx = uint(p.y) * uint(u_size) + uint(p.x);
    uint zb = dom_z0[idx];
    if (zb != 0xFFFFFFFFu) {
        float head = imageLoad(u_shadow_image, p).r;
        imageStore(u_shadow_image, p, vec4(min(head, uintBitsToFloat(zb)), 0.0, 0.0, 0.0));
        dom_z0[idx] = 0xFFFFFFFFu;
    }
}
