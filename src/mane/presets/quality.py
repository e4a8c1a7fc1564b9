"""Quality levels: the demo's and the viewer's workloads (``SOFTWARE`` for a CPU rasteriser, ``GPU``),
and the ladder of cheaper settings both step down on a software renderer below ``TARGET_FPS``
(the demo once before its clip, ``_calibrate``; the viewer while it runs, ``_adapt_quality``)."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import UsageError

# Workloads: what a CPU rasteriser renders at interactive rates, and what a GPU shows off.
@dataclass(frozen=True)
class Quality:
    name: str
    guides: int
    strands_per_guide: int
    points: int
    segments: int
    size: tuple[int, int]
    seconds: float
    fps: float
    msaa: int
    shading: str = "chiang"
    shadows: str = "deep_opacity"
    shadow_map_size: int | None = None
    """RenderSettings.shadow_map_size; None: the renderer's default (a fibre-resolving 1024)."""
    pcf: int | None = None
    """RenderSettings.pcf; None: the renderer's default."""
    sim_dt: float = 1.0 / 120.0
    friction: float = 0.05
    viewer_sim_dt: float | None = None
    """the viewer's simulation step (None: ``sim_dt``): the viewer's frame rate, not the clip's."""
    head_subdivisions: int = 5
    """detail of the default bust (5: 20,480 triangles; 4: 5,120, a quarter of llvmpipe's head pass)."""
    hair: str = "brown"
    """the hair colour preset (mane.render.shading.PRESETS): melanin drives the colour."""
    specular: float = 1.0
    """the R lobe's scale (1: physical; Kajiya-Kay's highlight too, scaled to Chiang's R lobe)."""
    multiple_scattering: str = "auto"
    """ShadingSettings.multiple_scattering ("auto": dual scattering, ~14 texel fetches a light)."""
    geometry: str = "ribbons"
    """RenderSettings.geometry ("lines": GL lines, on llvmpipe half the cost of ribbons' triangles)."""
    hair_shadow_lookup: str = "fragment"
    """RenderSettings.hair_shadow_lookup ("vertex": at the strands' points, for a CPU rasteriser)."""
    skin_bounce: float | None = None
    """RenderSettings.skin_bounce; None: the renderer's default (the skin's bounce on)."""
    rasterizer: str = "auto"
    """RenderSettings.rasterizer ("hardware" for SOFTWARE's lines on llvmpipe: 84 ms a frame
    against the compute rasteriser's 113, docs/performance.md)."""

    def render_settings(self, **changes):
        from ..grooming.scene import DEFAULT_SCENE_RENDER
        from ..render import RenderSettings
        from ..render.shading import hair_preset

        base = dict(**DEFAULT_SCENE_RENDER, size=self.size, strands_per_guide=self.strands_per_guide, segments=self.segments,
                    msaa=self.msaa, shading=self.shading, shadows=self.shadows,
                    geometry=self.geometry, hair_shadow_lookup=self.hair_shadow_lookup, rasterizer=self.rasterizer,
                    shading_options={"melanin": hair_preset(self.hair), "specular": self.specular,
                                     "multiple_scattering": self.multiple_scattering})
        base.update({k: v for k, v in (("shadow_map_size", self.shadow_map_size), ("pcf", self.pcf),
                                        ("skin_bounce", self.skin_bounce)) if v is not None})
        base.update(changes)
        return RenderSettings(**base)


# llvmpipe on 2 CPU cores: 960x540 at 15+ frames per second (simulation and rendering) with a
# shadow map instead of deep opacity, Kajiya-Kay instead of Marschner, fewer rendered strands
# and segments (12 points a guide: 11 segments, one per guide segment), and 48 Hz simulation
# steps (2 per frame of the 24 fps clip) without hair-hair friction; the viewer, at 15-20
# frames per second, steps at 30 Hz (2 steps a frame: each costs ~3.5 ms on llvmpipe, nearly
# all of it dispatch overhead). ``_calibrate`` (and the viewer) step further down
# (SOFTWARE_LADDER) on a machine slower than that.
SOFTWARE = Quality("software (scaled down for a CPU rasteriser)", 300, 3, 12, 6, (960, 540), 2.0, 24.0, 1,
                   shading="kajiya_kay", shadows="shadow_map", shadow_map_size=512, pcf=2,
                   sim_dt=1.0 / 48.0, friction=0.0, viewer_sim_dt=1.0 / 30.0, head_subdivisions=4,
                   multiple_scattering="none",   # dual scattering: ~20% of the light (brown; docs/quality.md)
                                                 # for ~25% of the hair pass on llvmpipe
                   hair_shadow_lookup="vertex",  # the hair's shadows at its points (docs/quality.md)
                   geometry="lines",             # sub-pixel strands: the same picture, half the hair pass
                   rasterizer="hardware",        # lines by the raster units: 84 ms a frame, compute 113
                   skin_bounce=0.0)              # unoccluded by the hair without deep opacity maps (2x the
                                                 # path tracer's bounce), and its grid's build ~50-75 ms
                                                 # a frame on llvmpipe
GPU = Quality("gpu", 4000, 16, 32, 32, (1280, 720), 4.0, 30.0, 4)
# Cheapest loss first. On llvmpipe at 960x540 (3 lights, the key light casting), CPU time a
# frame (simulation + rendering, 2026-12-02, docs/quality.md): 2 strands per guide saves ~3%,
# a 1-texel shadow filter ~2% (the look-ups are gathers now, 4 texels a fetch), no shadows ~20%
# (the shadow map's pass, the skin's look-ups).
SOFTWARE_LADDER = (
    # the default rig's fill and rim casting too (RenderSettings.shadow_lights 4): 14 fps before
    # it on 2 cores (2026-12-04), where the key's shadows alone left 19-28
    ("the key light's shadows only", dict(shadow_lights=1)),
    ("2 strands per guide", dict(strands_per_guide=2)),
    ("1-texel shadow filter", dict(pcf=1, head_pcf=1)),   # bilinear: 1 gather of 4 texels instead of 4, hair and skin
    ("no shadows", dict(shadows="none")),
    ("1 strand per guide", dict(strands_per_guide=1)),
)
TARGET_FPS = 15.0
HEADROOM = 1.05      # scale until a little above the target: the clip's loop also encodes video


def quality_named(name: str, software: bool) -> Quality:
    """``SOFTWARE`` or ``GPU`` by name; ``"auto"``: by the renderer (``software``: a CPU rasteriser)."""
    if name == "auto":
        return SOFTWARE if software else GPU
    if name not in ("software", "gpu"):
        raise UsageError(f"quality must be auto, software or gpu; got {name!r}")
    return SOFTWARE if name == "software" else GPU
