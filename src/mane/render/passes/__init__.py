"""The renderer's passes, in frame order; each has ``run(frame)`` and is timed by the profiler."""
from .base import Frame, Pass, View
from .deep_opacity import DeepOpacityPass
from .hair_pass import HairPass
from .head_pass import HeadPass
from .resolve import ResolvePass
from .shadow_map import ShadowMapPass

__all__ = ["Frame", "Pass", "View", "ShadowMapPass", "DeepOpacityPass", "HeadPass", "HairPass", "ResolvePass"]
