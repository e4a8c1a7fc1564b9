"""Named configurations over the layers below: the quality levels the demo and the viewer run at
(``quality.py``, with the ladder of cheaper settings both step down), the demo's scene and
simulation (``demo.py``), the viewer's style presets (``styles.py``) and Sintel's scene
(``sintel.py``). The procedural default scene itself is grown by ``mane.grooming.scene``.

    from mane.presets import SOFTWARE, demo_scene, demo_sim_settings
    groom, head = demo_scene(SOFTWARE)
"""
from __future__ import annotations

from .demo import demo_scene, demo_sim_settings
from .quality import GPU, HEADROOM, SOFTWARE, SOFTWARE_LADDER, TARGET_FPS, Quality, quality_named
from .sintel import SINTEL_CREDIT, SINTEL_STRANDS_PER_GUIDE, sintel_render_settings, sintel_scene
from .styles import STYLE_PRESETS

__all__ = [
    "Quality", "SOFTWARE", "GPU", "SOFTWARE_LADDER", "TARGET_FPS", "HEADROOM", "quality_named",
    "demo_scene", "demo_sim_settings", "STYLE_PRESETS",
    "SINTEL_CREDIT", "SINTEL_STRANDS_PER_GUIDE", "sintel_scene", "sintel_render_settings",
]
