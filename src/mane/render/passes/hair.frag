#version 430
#ifdef EARLY_Z
// after the hair's depth pre-pass (hair_pass.py): depth test before shading, never after
layout(early_fragment_tests) in;
#endif
#include "shading/hair_shading.glsl"
#include "hair_main.glsl"
