"""The strand renderer: tessellated guide curves, strand multiplication, ribbons, hair shading,
shadow and deep opacity maps, MSAA / supersampling, tone mapping; ``mane render`` drives it."""
from . import bindings  # noqa: F401  (registers the renderer's table with mane.gpu.glsl)
from .camera import Camera
from .image import render_image
from .lights import Light, default_lights, parse_light
from .renderer import Renderer
from .settings import RenderSettings
from .strand_buffers import StrandBuffers

__all__ = ["Camera", "Light", "Renderer", "RenderSettings", "StrandBuffers", "default_lights",
           "parse_light", "render_image"]
