#version 430
// The density splat's geometry shader emits nothing; a program needs a fragment stage.
layout(location = 0) out float frag;
void main() { frag = 0.0; }
