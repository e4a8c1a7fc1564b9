#version 430
// The hair fragment of the OIT methods: hair_main.glsl's shading (its main() renamed
// oit_hair_shade, which leaves the premultiplied colour in `frag`), then the method's stage.
#include "oit_extensions.glsl"
#include "shading/hair_shading.glsl"
#define main oit_hair_shade
#include "passes/hair_main.glsl"
#undef main
#include "oit_body.glsl"
