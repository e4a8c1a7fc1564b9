"""The viewer's style presets: named (simulation changes, render changes) over the current settings."""
from __future__ import annotations

# name -> (SimSettings changes, RenderSettings changes)
STYLE_PRESETS: dict[str, tuple[dict, dict]] = {
    "demo (soft, long)": (dict(local_shape_stiffness=0.05, global_shape_stiffness=0.02, global_shape_range=0.3,
                               bending_stiffness=0.0, damping=1.0), dict(curl_radius=0.0, clump_radius=0.006)),
    "loose and flowing": (dict(local_shape_stiffness=0.01, global_shape_stiffness=0.0, bending_stiffness=0.0,
                               damping=0.5), dict(curl_radius=0.0, stray_fraction=0.5)),
    "styled (stiff)": (dict(local_shape_stiffness=0.3, global_shape_stiffness=0.1, global_shape_range=0.6,
                            bending_stiffness=0.2, damping=2.0), dict(curl_radius=0.0, stray_fraction=0.2)),
    "curly": (dict(local_shape_stiffness=0.15, bending_stiffness=0.1, damping=1.5),
              dict(curl_radius=0.004, curl_frequency=8.0, clump_radius=0.004)),
    "wet (clumped)": (dict(local_shape_stiffness=0.02, damping=4.0),
                      dict(clump_radius=0.002, clump_tip=0.2, stray_fraction=0.05, curl_radius=0.0)),
}
