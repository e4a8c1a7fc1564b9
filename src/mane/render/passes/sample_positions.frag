#version 430
// Each sample of a multisampled target writes its own position in the pixel (gl_SamplePosition,
// which runs the shader once per sample): sample_resolve.py reads them back.
out vec4 frag;
void main() {
    frag = vec4(gl_SamplePosition, float(gl_SampleID), 1.0);
}
