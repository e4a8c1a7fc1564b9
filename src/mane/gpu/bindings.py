"""The buffer bindings of ``mane.gpu``'s own kernels (the limit microbenchmarks), declared once
and injected into each GLSL source under ``mane/gpu`` as ``#define`` lines (glsl.py)."""
from __future__ import annotations

from pathlib import Path

from .glsl import register_bindings

B_SRC = 0       # limits_copy.comp
B_DST = 1
B_WORDS = 0     # limits_atomic.comp

TABLE = register_bindings(Path(__file__).parent, globals())
