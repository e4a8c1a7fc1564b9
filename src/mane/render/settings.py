"""Render settings: one frozen dataclass, units in the field docs.

    s = RenderSettings(size=(320, 240), strands_per_guide=8, shadows="deep_opacity", msaa=4)
    s2 = s.replace(interpolation="bspline")

Lengths are metres, angles degrees (where said), fractions are of the strand's length
(root 0 .. tip 1) unless said otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

from ..errors import UsageError

INTERPOLATIONS = ("catmull_rom", "bspline", "bezier")
GEOMETRIES = ("ribbons", "lines")
PIPELINES = ("compute", "tessellation")
RASTERIZERS = ("auto", "hardware", "compute")
INTERPOLATION_MODES = ("single", "multi", "hybrid")
SHADOWS = ("none", "shadow_map", "deep_opacity", "adsm", "opacity_maps", "density")
DENSITY_SOURCES = ("auto", "strands", "simulator")
TONE_MAPS = ("aces", "reinhard", "none")
AA_MODES = ("none", "msaa2", "msaa4", "msaa8", "ssaa2", "msaa4+ssaa2")
MAX_TESS_LEVEL = 64   # the GL minimum for GL_MAX_TESS_GEN_LEVEL; llvmpipe and NVIDIA give 64
OIT_METHODS = ("none", "sorted_blending", "random_subsets", "a_buffer", "k_buffer", "dbk_buffer", "shortcut")
KBUFFER_MODES = ("auto", "atomic32", "atomic64", "interlock")


@dataclass(frozen=True)
class RenderSettings:
    """Everything the strand renderer needs besides the scene (camera, lights, groom, head)."""

    size: tuple[int, int] = (320, 240)
    """Output image (width, height), pixels."""
    # --- tessellation along the strand
    interpolation: str = "catmull_rom"
    """Curve through the guide points: "catmull_rom" (interpolates them, phantom end points),
    "bspline" (uniform cubic B-spline, approximating; passes through root and tip thanks to
    the phantom points) or "bezier" (the Vulkan hair work's cubic Bezier per segment, inner
    control points P_i + (P_{i+1} - P_{i-1})/6 and P_{i+1} - (P_{i+2} - P_i)/6: the Catmull-Rom
    curve itself in Bernstein form, evaluated by de Casteljau, so the same image)."""
    segments: int = 32
    """Rendered segments per strand (rounded up to a multiple of the guide's segments)."""
    # --- distance LOD (Chen: segments; TressFX 4.1: density and width)
    lod: bool = False
    """Distance level of detail: between lod_start and lod_end (camera to strand root, m) the
    segments per strand fall to lod_segment_percent (fractional tessellation), the strand count
    to lod_percent (strands fade out one by one) and the width rises to lod_width_multiplier."""
    lod_start: float = 1.0
    lod_end: float = 5.0
    lod_percent: float = 0.5
    """Fraction of strands kept at lod_end and beyond (TressFX LODPercent)."""
    lod_width_multiplier: float = 2.0
    """Strand width multiplier at lod_end (TressFX LODWidthMultiplier)."""
    lod_segment_percent: float = 0.25
    """Fraction of ``segments`` kept at lod_end (Chen's segment LOD)."""
    lod_min_segments: int = 4
    """Fewest segments per strand the LOD goes down to."""
    # --- strand multiplication
    strands_per_guide: int = 16
    """Rendered strands per guide (the guide itself is strand 0). Beyond 64 (the tessellation
    limit) a guide is drawn in more instances of 64 isolines."""
    interpolation_mode: str = "single"
    """"single": clumps around one guide; "multi": every rendered strand is the barycentric
    blend of 3 guide curves plus its root offset (Woodhouse; weights from grooming's
    GuideWeights via ``Renderer.set_guide_weights``, else random barycentrics hashed per strand
    over each guide and its two nearest guides); "hybrid": "multi", except strands whose 3
    guides straddle a collider (``colliders``, else the default head's SDF) take the
    single-strand form around their heaviest guide."""
    colliders: tuple = ()
    """Hybrid interpolation's colliders: ellipsoids (cx, cy, cz, rx, ry, rz) in metres (a sphere
    has rx = ry = rz). Empty: the default head's distance field when the head is the default."""
    hybrid_margin: float = 0.002
    """A straight segment between guide points straddles a collider when it passes deeper than
    this (m) inside it (roots sit on the scalp: chords between them dip a little inside)."""
    clump_radius: float = 0.006
    """Radius (m) of the disc, perpendicular to the guide, on which a clump's strands sit."""
    clump_root: float = 0.25
    """Clump radius at the root, as a fraction of clump_radius (root taper)."""
    clump_tip: float = 0.5
    """Clump radius at the tip, as a fraction of clump_radius (tip taper; <1 gathers tips)."""
    stray_fraction: float = 0.5
    """Probability that a rendered strand deviates from its clump (the Vulkan hair / Rapp 2014:
    0.5); a deviating strand takes one of five equiprobable shapes (mane.render.strand_math)."""
    stray_amount: float = 1.5
    """How far a deviating strand leaves the clump, in clump radii, at its most (the sharp
    exponential's tip)."""
    curl_radius: float = 0.0
    """Render-time curl: radius (m) of a helix around each strand's curve (0: off). It grows
    from 0 at the root to full by 10% of the strand."""
    curl_frequency: float = 6.0
    """Curl turns per strand, root to tip (each strand starts at its own hashed phase)."""
    strand_spread: float = 5.0
    """RMS angle (degrees) by which each rendered strand's direction, as shaded, tilts from its
    curve's (random per strand, Rayleigh-distributed, in a random direction; the kept guide is
    not tilted): the strands of a clump then catch the highlight at different places instead of
    as one flat white patch. 0: the curves' own tangents."""
    keep_guide: bool = True
    """Render the guide itself as the clump's strand 0 (offset 0)."""
    # --- geometry
    geometry: str = "ribbons"
    """"ribbons": camera-facing quads from a geometry shader; "lines": GL_LINES."""
    pipeline: str = "compute"
    """How the strands reach the rasteriser: "compute" (a compute pass writes every rendered
    strand's tessellated points once per frame, shared by all passes, which draw them by
    vertex pulling: instanced strips, no tessellation or geometry stages; TressFX's way) or
    "tessellation" (isolines + geometry-shader ribbons in every pass). The hardware OIT methods
    always use "tessellation"; the distance LOD is expanded too (once per camera position)."""
    rasterizer: str = "auto"
    """Who turns the hair into pixels: "hardware" (the GPU's raster units: triangle strips,
    MSAA), "compute" (compute shaders scan-convert every segment into a per-sample visibility
    buffer, nearest segment by atomic min, coverage accumulated, then each pixel shaded once
    per visible segment: Unreal's and Frostbite's way for thin strands; ``msaa`` n becomes a
    ceil(sqrt(n))^2 grid of samples per pixel for the hair, the head keeps n-sample MSAA unless
    ``head_msaa`` is off) or "auto": "compute" on GPUs built for computing with few raster units
    (NVIDIA H100/H200/H800/A100/A800/GH200/B100/B200), else "hardware". Needs
    pipeline="compute"; of the OIT methods the A-buffer, K-buffer, DBK-buffer and ShortCut have
    compute forms (mane.render.oit.compute), sorted blending and random subsets draw by
    hardware."""
    head_msaa: bool = True
    """With the compute rasteriser: draw the head with ``msaa`` samples (its silhouette
    antialiased) or with one. On GPUs with few raster units (H100/H200 class) the multisampled
    clear and resolve cost more than the whole hair (docs/performance.md); the hair's own
    samples do not depend on it."""
    depth_prepass: bool = True
    """With MSAA: draw the hair's depth first (its coverage as a sample mask), then shade it with
    the depth test LEQUAL and no depth writes, so the hair BSDF runs once per pixel and visible
    strand instead of once per overlapping strand."""
    width: float = 0.0006
    """Strand width (m) at the root (ribbons)."""
    width_tip: float = 0.35
    """Width at the tip as a fraction of the root width (taper)."""
    min_pixel_width: float = 1.0
    """Ribbons narrower than this (pixels) are drawn this wide with coverage alpha = true/shown
    width, so sub-pixel strands fade instead of flickering. 0 turns coverage alpha off."""
    # --- shading and lights
    shading: str = "chiang"
    """Hair shading model name (mane.render.shading.ShadingSettings): "chiang" (Chiang et al.
    2016, pbrt's and Mitsuba's hair model, with dual scattering) by default."""
    shading_options: dict = field(default_factory=dict)
    """Other ShadingSettings fields (e.g. {"melanin": (0.3, 0.1), "multiple_scattering": "none",
    "roughness": 0.12}). Colour comes from melanin (default the "brown" preset,
    mane.render.shading.PRESETS)."""
    hair_color: tuple[float, float, float] | None = None
    """None (melanin drives the colour), or a linear RGB colour that replaces melanin: an
    explicit opt-in (ShadingSettings.color)."""
    use_file_colors: bool = True
    """A groom that carries its own colours, widths or transparency (cyHair arrays, USD
    displayColor/widths, PLY properties...) renders with them (their mean colour, median root
    width and taper, mean opacity: mane.render.file_appearance) in place of hair_color, width,
    width_tip and oit_opacity; False: the scene's hair model decides."""
    ambient: float = 0.12
    """Ambient light (linear radiance, white) added to the hair and the head."""
    skin_color: tuple[float, float, float] = (0.5, 0.32, 0.24)
    """Linear RGB albedo of the head mesh (Lambert)."""
    background: tuple[float, float, float] = (0.16, 0.17, 0.19)
    """sRGB background colour in [0, 1]."""
    draw_head: bool = True
    # --- shadows
    shadows: str = "deep_opacity"
    """"none", "shadow_map" (depth + PCF, hair and head cast), "deep_opacity" (Yuksel and
    Keyser: 3 opacity layers after the first hair depth z0, in one RGBA texture), "adsm"
    (TressFX's approximated deep shadow map), "opacity_maps" (Kim and Neumann: osm_slices
    slices in several render targets) or "density" (Woodhouse: a ray march through a 3D
    density texture). The head casts through its own shadow map with every method."""
    shadow_lights: int = 1
    """How many lights, from light 0, cast shadows (1..4; Chen's scene: 3 lights, 2 casting).
    Each has its own maps: a shadow map, and with "deep_opacity" a deep opacity map; with
    "adsm", "opacity_maps" or "density" the lights after light 0 use a shadow map (hair and head)."""
    shadow_map_size: int = 512
    """Shadow / opacity map resolution (texels per side); 128..2048 is the intended range."""
    pcf: int = 2
    """PCF kernel: a pcf x pcf texel box, bilinearly weighted ((pcf + 1)^2 taps; 1 = bilinear
    interpolation between the 4 nearest texels), for every shadow method's look-up. The
    default's 9 taps are as many as the earlier 3 x 3 box of nearest texels."""
    shadow_bias: float = 3.0
    """Depth bias, in shadow-map texels (world size of a texel)."""
    shadow_normal_offset: float = 1.5
    """Surfaces receiving shadows (the head): the shadow look-up point moves off the surface
    along its normal by this many texels of the map, times sin(angle between normal and light)."""
    shadow_slope_bias: float = 1.5
    """Surfaces receiving shadows (the head): more depth bias, in texels per unit of
    tan(angle between normal and light) (up to 10), against acne and banding at grazing light."""
    dom_layers: tuple[float, float, float] = (0.05, 0.15, 1.0)
    """Deep opacity layer ends after z0, as fractions of the hair's depth extent seen from the light."""
    strand_opacity: float = 0.35
    """Opacity one strand adds in the deep opacity map (per covered texel)."""
    shadow_density: float = 3.0
    """Scale of the opacity -> transmittance exponent: T = exp(-density * O). Every method uses
    it: one strand crossed passes exp(-shadow_density * strand_opacity) of the light."""
    adsm_spacing: float = 10.0
    """ADSM (TressFX's approximated deep shadow map, shadows="adsm"): the fibre spacing along
    the light, in strand widths; n = (depth behind the first hair occluder) / (adsm_spacing *
    width) strands are assumed crossed, T = (1 - alpha)^n with 1 - alpha = exp(-shadow_density *
    strand_opacity). Smaller = darker (Hunz §4)."""
    osm_slices: int = 16
    """Opacity shadow maps (shadows="opacity_maps"): uniform slices between the hair's nearest
    and farthest light depth; 4 per RGBA32F target, 4..32 (8 render targets)."""
    density_resolution: int = 64
    """Density ray march (shadows="density"): nodes per side of the 3D density texture built
    from the rendered strands (16..256). With density_source="simulator" the simulator's
    friction grid (its own resolution) is used instead."""
    density_source: str = "auto"
    """"strands": splat the rendered strands (tessellated, clumped) into the 3D texture every
    frame; "simulator": the simulator's hair-hair friction grid (guide particles, scaled to
    the rendered strands); "auto": the simulator's grid when the strands come from a
    simulator whose grid has been built, otherwise the strands."""
    density_step: float = 0.5
    """Ray-march step, in grid cells."""
    # --- anti-aliasing and output
    msaa: int = 4
    """Samples per pixel (1, 2, 4, 8; clamped to GL_MAX_SAMPLES)."""
    supersample: int = 1
    """1, or 2: render at twice the size per axis and resolve with Chen's 5-tap filter."""
    tone_mapping: str = "aces"
    exposure: float = 1.0
    # --- order-independent transparency (mane.render.oit)
    oit: str = "none"
    """Hair transparency: "none" (depth-tested premultiplied blending, or a coverage sample mask
    with MSAA), "sorted_blending" (guide segments sorted by view depth on the GPU, blended back to
    front), "random_subsets" (oit_k subsets, the nearest fragment of each, sorted per pixel),
    "a_buffer" (per-pixel linked lists of every fragment), "k_buffer" (the oit_k nearest per
    pixel), "dbk_buffer" (Hunz's depth-bounded lists over an opaque layer) or "shortcut"
    (TressFX: the 3 nearest plus the total transmittance). Any method but "none" renders
    single-sampled (the hair's own coverage alpha anti-aliases it)."""
    oit_k: int = 8
    """Fragments sorted per pixel: the A-buffer's and DBK-buffer's resolve (0: all of them),
    the K-buffer's slots, the number of random subsets. The rest of a list is blended
    unsorted behind the k nearest."""
    oit_opacity: float = 1.0
    """Strand opacity in the camera view for the OIT methods (Hunz's alpha_s), times the
    coverage alpha; 1 keeps the coverage alpha alone."""
    oit_nodes_per_pixel: float = 8.0
    """First size of the A-buffer / DBK-buffer node pool, in nodes per pixel; it grows (to what
    the frame needed, plus a quarter) after a frame that overflowed."""
    oit_max_bytes: int = 0
    """Upper bound on the node pool, bytes (0: what the GPU allows)."""
    oit_auto_shift: bool = True
    """DBK-buffer: choose the layer's depth shift every frame from the previous frame's
    fragment depths, so that the layer reaches where the transmittance falls below
    oit_threshold (about k = log(oit_threshold) / log(1 - alpha) fragments)."""
    oit_depth_shift: float = 0.02
    """DBK-buffer: the layer's depth (m) behind the nearest hair when oit_auto_shift is off
    (and the first frame's guess when it is on)."""
    oit_threshold: float = 0.02
    """DBK-buffer automatic shift: the transmittance the layer should reach."""
    oit_shift_quantile: float = 0.95
    """DBK-buffer automatic shift: the fraction of hair pixels whose layer reaches that
    transmittance (the shift is this quantile of the per-pixel depths needed)."""
    oit_dbk_behind: str = "blend"
    """DBK-buffer: the hair behind the layer is drawn "opaque" (Hunz) or "blend"-ed with its
    alpha (depth-tested, unsorted) before the layer's lists are blended over it."""
    oit_kbuffer: str = "auto"
    """K-buffer insertion: "atomic32" (two geometry passes: 32-bit depth keys kept by atomicMin
    bubbling, then the colours of the kept keys), "atomic64" (one pass: 64-bit depth|colour
    keys, GL_NV_shader_atomic_int64), "interlock" (one pass: fragment shader interlock) or
    "auto" (atomic64, else interlock, else atomic32)."""

    def __post_init__(self) -> None:
        w, h = (int(v) for v in self.size)
        if not (8 <= w <= 8192 and 8 <= h <= 8192):
            raise UsageError(f"image size must be within 8..8192 pixels per side, got {self.size}")
        object.__setattr__(self, "size", (w, h))
        for name, allowed in (("interpolation", INTERPOLATIONS), ("geometry", GEOMETRIES), ("pipeline", PIPELINES),
                              ("rasterizer", RASTERIZERS),
                              ("shadows", SHADOWS), ("tone_mapping", TONE_MAPS),
                              ("interpolation_mode", INTERPOLATION_MODES)):
            if getattr(self, name) not in allowed:
                raise UsageError(f"{name} must be one of {', '.join(allowed)}; got {getattr(self, name)!r}")
        if not 1 <= int(self.segments) <= 4096:
            raise UsageError(f"segments per strand must be in 1..4096, got {self.segments}")
        if not 1 <= int(self.strands_per_guide) <= 4096:
            raise UsageError(f"strands_per_guide must be in 1..4096, got {self.strands_per_guide}")
        if int(self.msaa) not in (1, 2, 4, 8, 16):
            raise UsageError(f"msaa must be 1, 2, 4, 8 or 16 samples, got {self.msaa}")
        if int(self.supersample) not in (1, 2):
            raise UsageError(f"supersample must be 1 or 2, got {self.supersample}")
        if not 1 <= int(self.pcf) <= 9:
            raise UsageError(f"pcf taps per side must be in 1..9, got {self.pcf}")
        if not 1 <= int(self.shadow_lights) <= 4:
            raise UsageError(f"shadow_lights must be in 1..4, got {self.shadow_lights}")
        if not 16 <= int(self.shadow_map_size) <= 8192:
            raise UsageError(f"shadow_map_size must be in 16..8192, got {self.shadow_map_size}")
        if int(self.osm_slices) % 4 or not 4 <= int(self.osm_slices) <= 32:
            raise UsageError(f"osm_slices must be a multiple of 4 in 4..32, got {self.osm_slices}")
        if not 16 <= int(self.density_resolution) <= 256:
            raise UsageError(f"density_resolution must be in 16..256, got {self.density_resolution}")
        if self.density_source not in DENSITY_SOURCES:
            raise UsageError(f"density_source must be one of {', '.join(DENSITY_SOURCES)}; got {self.density_source!r}")
        if not 0.05 <= float(self.density_step) <= 4.0:
            raise UsageError(f"density_step must be in 0.05..4 cells, got {self.density_step}")
        if not float(self.adsm_spacing) > 0:
            raise UsageError(f"adsm_spacing must be > 0 strand widths, got {self.adsm_spacing}")
        d = tuple(float(x) for x in self.dom_layers)
        if len(d) != 3 or not (0 < d[0] < d[1] < d[2]):
            raise UsageError(f"dom_layers must be 3 increasing positive fractions, got {self.dom_layers}")
        object.__setattr__(self, "dom_layers", d)
        for name in ("width", "clump_radius", "min_pixel_width", "stray_fraction", "stray_amount",
                     "strand_opacity", "ambient", "exposure", "shadow_density", "shadow_bias",
                     "shadow_normal_offset", "shadow_slope_bias",
                     "curl_radius", "curl_frequency", "hybrid_margin", "lod_start", "strand_spread"):
            if float(getattr(self, name)) < 0:
                raise UsageError(f"{name} must be >= 0, got {getattr(self, name)}")
        import math

        for f in fields(self):   # NaN passes every comparison: refuse it (and infinity) once, here
            v = getattr(self, f.name)
            items = v if isinstance(v, tuple) and f.name != "colliders" else (v,)
            for x in items:
                if isinstance(x, float) and not math.isfinite(x):
                    raise UsageError(f"{f.name} must be finite, got {v}")
        for name in ("hair_color", "skin_color", "background"):
            c = getattr(self, name)
            if c is not None and (len(c) != 3 or not all(math.isfinite(float(x)) and float(x) >= 0 for x in c)):
                raise UsageError(f"{name} must be 3 finite numbers >= 0 (linear RGB), got {c}")
        if not 0.0 <= float(self.stray_fraction) <= 1.0:
            raise UsageError(f"stray_fraction is a probability in 0..1, got {self.stray_fraction}")
        if self.lod and not float(self.lod_end) > float(self.lod_start):
            raise UsageError(f"lod_end must be beyond lod_start, got {self.lod_start}..{self.lod_end}")
        if not (0.0 < float(self.lod_percent) <= 1.0 and 0.0 < float(self.lod_segment_percent) <= 1.0):
            raise UsageError("lod_percent and lod_segment_percent must be in (0, 1]")
        if not float(self.lod_width_multiplier) > 0 or not 1 <= int(self.lod_min_segments) <= 4096:
            raise UsageError("lod_width_multiplier must be > 0 and lod_min_segments in 1..4096")
        cols = tuple(tuple(float(x) for x in c) for c in self.colliders)
        if any(len(c) != 6 or min(c[3:]) <= 0 for c in cols):
            raise UsageError("colliders are ellipsoids (cx, cy, cz, rx, ry, rz) with positive radii")
        object.__setattr__(self, "colliders", cols)
        if self.oit not in OIT_METHODS:
            raise UsageError(f"oit must be one of {', '.join(OIT_METHODS)}; got {self.oit!r}")
        if self.oit_dbk_behind not in ("opaque", "blend"):
            raise UsageError(f"oit_dbk_behind must be 'opaque' or 'blend'; got {self.oit_dbk_behind!r}")
        if self.oit_kbuffer not in KBUFFER_MODES:
            raise UsageError(f"oit_kbuffer must be one of {', '.join(KBUFFER_MODES)}; got {self.oit_kbuffer!r}")
        if not 0 <= int(self.oit_k) <= 64 or (self.oit in ("k_buffer", "random_subsets") and int(self.oit_k) < 1):
            raise UsageError(f"oit_k must be in 0..64 (1..64 for the K-buffer and random subsets), got {self.oit_k}")
        if not 0.0 < float(self.oit_opacity) <= 1.0:
            raise UsageError(f"oit_opacity must be in (0, 1], got {self.oit_opacity}")
        if not 0.05 <= float(self.oit_nodes_per_pixel) <= 1024:
            raise UsageError(f"oit_nodes_per_pixel must be in 0.05..1024, got {self.oit_nodes_per_pixel}")
        if int(self.oit_max_bytes) < 0 or not float(self.oit_depth_shift) > 0:
            raise UsageError("oit_max_bytes must be >= 0 and oit_depth_shift > 0")
        if not (0.0 < float(self.oit_threshold) < 1.0 and 0.0 < float(self.oit_shift_quantile) <= 1.0):
            raise UsageError("oit_threshold must be in (0, 1) and oit_shift_quantile in (0, 1]")

    def replace(self, **changes) -> "RenderSettings":
        return replace(self, **changes)

    @property
    def render_size(self) -> tuple[int, int]:
        """The size actually rasterised (size x supersample)."""
        return (self.size[0] * self.supersample, self.size[1] * self.supersample)

    @classmethod
    def field_names(cls) -> list[str]:
        return [f.name for f in fields(cls)]


def aa_settings(name: str) -> dict:
    """--aa NAME -> {msaa, supersample, min_pixel_width}: none, msaa2/4/8, ssaa2, msaa4+ssaa2, coverage."""
    name = name.lower()
    table = {
        "none": dict(msaa=1, supersample=1, min_pixel_width=0.0),
        "coverage": dict(msaa=1, supersample=1),
        "msaa2": dict(msaa=2, supersample=1),
        "msaa4": dict(msaa=4, supersample=1),
        "msaa8": dict(msaa=8, supersample=1),
        "ssaa2": dict(msaa=1, supersample=2),
        "msaa4+ssaa2": dict(msaa=4, supersample=2),
    }
    if name not in table:
        raise UsageError(f"--aa must be one of {', '.join(table)}; got {name!r}")
    return table[name]
