#version 430
// As oit_hair.frag, with the stand-in shading (used only while mane.render.shading is absent).
#include "oit_extensions.glsl"
#include "passes/fallback_shading.glsl"
#define main oit_hair_shade
#include "passes/hair_main.glsl"
#undef main
#include "oit_body.glsl"
