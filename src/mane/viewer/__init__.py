"""The interactive viewer (``mane view``): a GLFW window through moderngl-window, the simulator
and the renderer on its OpenGL context, and a Dear ImGui panel generated from the settings.

    from mane.viewer import Viewer, display_available
    if display_available():
        Viewer(mane.load("hair.tfx")).run()

Importing this package is cheap; the window libraries load when a Viewer is made.
"""
from __future__ import annotations

__all__ = ["Viewer", "display_available", "create_window", "OrbitControl", "Recorder", "save_screenshot"]


def __getattr__(name):
    if name in ("Viewer", "display_available", "create_window"):
        from . import window

        return getattr(window, name)
    if name == "OrbitControl":
        from .camera_control import OrbitControl

        return OrbitControl
    if name in ("Recorder", "save_screenshot"):
        from . import recorder

        return getattr(recorder, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
