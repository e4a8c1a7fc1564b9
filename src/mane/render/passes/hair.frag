#version 430
#include "shading/hair_shading.glsl"
#include "hair_main.glsl"
