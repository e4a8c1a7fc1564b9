#version 450
// As oit_hair.frag, GLSL 4.50: the K-buffer's 64-bit atomic and interlock forms (glslang wants 4.50 for
// GL_ARB_fragment_shader_interlock and GL_ARB_gpu_shader_int64; NVIDIA takes either).
#include "oit_extensions.glsl"
#include "shading/hair_shading.glsl"
#define main oit_hair_shade
#include "passes/hair_main.glsl"
#undef main
#include "oit_body.glsl"
