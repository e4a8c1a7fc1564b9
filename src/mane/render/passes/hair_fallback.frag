#version 430
// Used only while mane.render.shading is absent (a stand-in with the same interface).
#include "fallback_shading.glsl"
#include "hair_main.glsl"
