"""The simulator's buffer bindings, declared once.

Every name here is injected into each GLSL source under ``mane/sim`` as a ``#define`` by
``mane.gpu.glsl`` (``layout(std430, binding = B_POSITIONS)``), and the Python that binds the
buffers uses the same constant. Numbers repeat between kernels that never share a program;
within one program they differ (tests/test_bindings.py). The grid box's binding is a define
the caller passes (``BOUNDS_BINDING``: ``bounds.BOUNDS_BINDING``, or another slot when a
kernel already uses that one), as is the grid's in ``integrate.comp`` (``GRID_BINDING``).
"""
from __future__ import annotations

from pathlib import Path

from ..gpu.bindings import B_BOUNDS as GPU_BOUNDS
from ..gpu.bindings import B_POSITIONS as GPU_POSITIONS
from ..gpu.glsl import register_bindings

# the solver's state (sim_common.glsl; state.BINDINGS names them by buffer)
B_POSITIONS = GPU_POSITIONS   # xyz m, w inverse mass (the grid box kernel's too: gpu.bindings)
B_PREV_POSITIONS = 1      # the start of the step
B_VELOCITIES = 2          # xyz m/s
B_REST_POSITIONS = 3      # head frame, w inverse mass
B_REST_INFO = 4           # segment length, arc, bend angle, base length
B_CORRECTIONS = 5         # DFTL d_k
B_SHAPE_REFS = 6
B_ROOT_FRAMES = 7
B_COLLIDERS = 8           # colliders.py's layout
B_GUARD = 9               # NaN guard counters
# the grid kernels (grid_friction.py, flip.py, bounds.py): particles in, grid out
B_PARTICLE_VELOCITIES = 1  # the particles' velocities next to B_POSITIONS
B_ACCUMULATOR = 2         # splat accumulator (fixed-point or float atomics)
B_GRID = 3                # the normalised grid (velocity, density)
B_TILES = 4               # splat_binned.comp's bins
B_ORDER = 5
B_SORTED = 6              # splat_binned.comp's particle positions and velocities copied in sorted order
# the grid's box (bounds.GridBounds): B_BOUNDS for every grid kernel; the strand solver, whose
# B_ROOT_FRAMES holds 7, reads the grid and its box at B_GATHER_GRID / B_GATHER_BOUNDS
B_BOUNDS = GPU_BOUNDS    # where mane.gpu.bounds writes the box
B_GATHER_GRID = 10
B_GATHER_BOUNDS = 11
# FLIP's pressure solve (flip.py)
B_FACES = 3
B_CELLS = 4
B_PARTIALS = 5
B_SCALARS = 6

# texture units
TEX_SDF_FIRST = 5         # signed distance fields: 5, 6, ... (sdf.py, simulator.py)
TEX_SPLAT = 0             # the layered splat texture read back into the grid

TABLE = register_bindings(Path(__file__).parent, globals())
