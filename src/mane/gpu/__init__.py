"""The one place that talks to OpenGL: contexts, GLSL programs, buffers and GPU timing.

Nothing outside ``mane.gpu``, ``mane.sim`` and ``mane.render`` makes GL calls.
"""
from __future__ import annotations

from .context import (  # noqa: F401
    MIN_GL_VERSION,
    get_context,
    headless_context,
    is_software_renderer,
    renderer_name,
)
from .glsl import clear_cache, compute_shader, load_source, program  # noqa: F401
from . import bindings  # noqa: F401  (registers the table of gpu's own kernels)
from .capabilities import Capabilities, Feature, GPUMemory, get_capabilities, gpu_memory  # noqa: F401
from .buffers import buffer, check_allocation  # noqa: F401
from .profiler import GpuProfiler  # noqa: F401
