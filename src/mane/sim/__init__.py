"""GPU strand simulation: settings, state buffers, the solver, colliders, wind, head motion.

    from mane.sim import Simulator, SimSettings, Sphere
    sim = Simulator(groom.resampled(16), colliders=[Sphere(center=(0, 1.6, 0), radius=0.1)])
    sim.advance(1 / 60)
"""
from __future__ import annotations

from . import bindings, head_motion  # noqa: F401  (bindings: registers the sim's table)
from .colliders import Capsule, Collider, Ellipsoid, MeshCollider, Sphere  # noqa: F401
from .settings import SimSettings, SolverTuning, iteration_stiffness  # noqa: F401
from .simulator import PASSES, SimSnapshot, Simulator  # noqa: F401
from .state import SimState, check_fits, estimate_bytes  # noqa: F401
from .wind import WindSettings  # noqa: F401

__all__ = [
    "Simulator", "SimSettings", "SimState", "SimSnapshot", "WindSettings", "PASSES",
    "Collider", "Sphere", "Ellipsoid", "Capsule", "MeshCollider",
    "head_motion", "iteration_stiffness", "check_fits", "estimate_bytes",
]
