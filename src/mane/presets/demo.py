"""The demo's scene: the procedural default groom and head at a quality level, and its simulation."""
from __future__ import annotations

from .quality import Quality


def demo_scene(q: Quality):
    """(groom, head): the procedural default with ``q.guides`` strands of ``q.points`` points."""
    from ..grooming.scene import default_scene

    return default_scene(num_guides=q.guides, points=q.points, subdivisions=q.head_subdivisions)


def demo_sim_settings(q: Quality, wind: bool = True, dt: float | None = None):
    """The demo's simulation: soft long hair, gusts from the front-left (wind acts through drag).
    ``dt``: the step (default ``q.sim_dt``)."""
    from ..sim import SimSettings, WindSettings

    return SimSettings(
        # Enough shape to keep the groomed parting and waves (and the face clear) while the
        # head nods and the wind blows; the tips still swing by a centimetre or two.
        dt=q.sim_dt if dt is None else float(dt), friction=q.friction, local_shape_stiffness=0.3, global_shape_stiffness=0.1,
        global_shape_range=0.6, drag=1.0 if wind else 0.0,
        wind=WindSettings(velocity=(0.6, 0.0, 1.2), gust=1.0, turbulence=0.6) if wind else WindSettings(),
    )
