#version 430
// mane bench limits: the raster units' peak on hair-like geometry. One instance per strip of
// SEGMENTS quads, u_seg_px pixels along x and u_width_px across, drawn as a triangle strip of
// 2 (SEGMENTS + 1) vertices pulled from gl_VertexID (as hair_pull.vert draws a strand): every
// triangle is u_seg_px x u_width_px / 2 pixels. Strips tile the target row by row, pixel
// aligned, u_layers times over (instances beyond one layer start again at the top).
uniform vec2 u_size;           // target pixels
uniform int u_strips_per_row;
uniform int u_rows;            // rows of strips in a layer
uniform float u_seg_px;
uniform float u_width_px;

void main() {
    int strip = gl_InstanceID % (u_rows * u_strips_per_row);
    int row = strip / u_strips_per_row;
    int col = strip - row * u_strips_per_row;
    int i = gl_VertexID >> 1;
    int side = gl_VertexID & 1;
    vec2 p = vec2((float(col * SEGMENTS) + float(i)) * u_seg_px, (float(row) + float(side)) * u_width_px);
    gl_Position = vec4(p / u_size * 2.0 - 1.0, 0.5, 1.0);
}
