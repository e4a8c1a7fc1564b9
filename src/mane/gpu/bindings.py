"""The buffer bindings of ``mane.gpu``'s own kernels (the limit microbenchmarks), declared once
and injected into each GLSL source under ``mane/gpu`` as ``#define`` lines (glsl.py)."""
from __future__ import annotations

from pathlib import Path

from .glsl import register_bindings

B_SRC = 0       # limits_copy.comp
B_DST = 1
B_WORDS = 0     # limits_atomic.comp
# the grid box (bounds.py, bounds.comp): the particles in, the box out, where mane.sim's grid
# kernels read it (mane.sim.bindings takes these two from here)
B_POSITIONS = 0
B_BOUNDS = 7
B_FILL = 0      # fill_words.comp (clear.py)
# image units
IMG_CLEAR = 0     # clear_image.comp (clear.py)

TABLE = register_bindings(Path(__file__).parent, globals())
