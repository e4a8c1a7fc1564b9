// Extensions of the K-buffer's single-pass forms; first in the fragment shader, before any
// declaration (the OIT_* defines come from Python: mane.render.oit.k_buffer).
#if defined(OIT_KBUF_MODE) && OIT_METHOD == 4 && OIT_KBUF_MODE == 1 && OIT_STAGE == 1
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_NV_shader_atomic_int64 : require
#elif defined(OIT_KBUF_MODE) && OIT_METHOD == 4 && OIT_KBUF_MODE == 2 && OIT_STAGE == 1
#extension GL_ARB_fragment_shader_interlock : require
#endif
