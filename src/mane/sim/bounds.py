"""The simulator's particle helpers for its grids. The grid's box (``GridBounds``, its NumPy twin
``padded_box``) and the small GL helpers live in ``mane.gpu.bounds`` (the renderer's density grid
uses the box too); they are re-exported here for the simulator's modules."""
from __future__ import annotations

import numpy as np

from ..gpu.bounds import (  # noqa: F401
    BOUNDS_BINDING,
    BOUNDS_BYTES,
    GridBounds,
    check_particle_buffers,
    groups,
    padded_box,
    set_uniforms,
    storage_barrier,
)


def is_state(obj) -> bool:
    """True for a simulator state (``.positions``, ``.velocities``, ``.num_particles``), not a buffer."""
    return not hasattr(obj, "bind_to_storage_buffer") and hasattr(obj, "num_particles")


def particle_masses(inverse_masses: np.ndarray, pinned_mass: float) -> np.ndarray:
    """The mass each particle brings to a grid: 1/w, or ``pinned_mass`` where w = 0 (pinned)."""
    w = np.asarray(inverse_masses, dtype=np.float64)
    safe = np.where(w > 0, w, 1.0)
    return np.where(w > 0, 1.0 / safe, float(pinned_mass))
