"""The renderer's passes, in frame order; each has ``run(frame)`` and is timed by the profiler."""
from .adsm import ADSMPass
from .base import Frame, Pass, View
from .deep_opacity import DeepOpacityPass
from .density import DensityPass
from .extra_shadows import ExtraShadowsPass
from .hair_pass import HairPass
from .head_pass import HeadPass
from .opacity_maps import OpacityMapsPass
from .resolve import ResolvePass
from .shadow_map import ShadowMapPass
from .skin_bounce import SkinBouncePass

__all__ = ["Frame", "Pass", "View", "ShadowMapPass", "DeepOpacityPass", "ADSMPass", "OpacityMapsPass", "DensityPass", "ExtraShadowsPass", "SkinBouncePass", "HeadPass", "HairPass", "ResolvePass"]
