// The grid's velocity at p: the trilinear (tent) interpolation of the node velocities
// (grid friction's V(x)). Needs grid_nodes.glsl and a `grid` buffer of vec4(V, mass) per node.
vec3 grid_velocity(vec3 p) {
    NodeStencil s = node_stencil(p);
    vec3 vg = vec3(0.0);
    for (int c = 0; c < 8; ++c) {
        ivec3 corner = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        vg += corner_weight(s.frac, corner) * grid[node_index(s.base + corner)].xyz;
    }
    return vg;
}
