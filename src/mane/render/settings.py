"""Render settings: one frozen dataclass, each field declared once (``mane.setting``: its range,
choices, unit and help), validated from those declarations.

    s = RenderSettings(size=(320, 240), strands_per_guide=8, shadows="deep_opacity", msaa=4)
    s2 = s.replace(interpolation="bspline")

Lengths are metres, angles degrees (where said), fractions are of the strand's length
(root 0 .. tip 1) unless said otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

from ..errors import UsageError
from ..setting import setting, validate
from .shading import MODELS

INTERPOLATIONS = ("catmull_rom", "bspline", "bezier")
GEOMETRIES = ("ribbons", "lines")
PIPELINES = ("compute", "tessellation")
RASTERIZERS = ("auto", "hardware", "compute")
INTERPOLATION_MODES = ("single", "multi", "hybrid")
SHADOWS = ("none", "shadow_map", "deep_opacity", "adsm", "opacity_maps", "density")
SHADOW_LOOKUPS = ("fragment", "vertex")
DENSITY_SOURCES = ("auto", "strands", "simulator")
TONE_MAPS = ("aces", "reinhard", "none")
AA_MODES = ("none", "msaa2", "msaa4", "msaa8", "ssaa2", "msaa4+ssaa2")
MAX_TESS_LEVEL = 64   # the GL minimum for GL_MAX_TESS_GEN_LEVEL; llvmpipe and NVIDIA give 64
OIT_METHODS = ("none", "sorted_blending", "random_subsets", "a_buffer", "k_buffer", "dbk_buffer", "shortcut")
KBUFFER_MODES = ("auto", "atomic32", "atomic64", "interlock")


def shading_option_names() -> dict[str, str]:
    """The keys ``RenderSettings.shading_options`` takes, with their types: ShadingSettings'
    fields but the model and the colour (``shading`` and ``hair_color`` set those). A "str" key's
    text is taken as it is on the command line ("none" is a multiple-scattering mode, not None)."""
    from .shading import ShadingSettings

    return {f.name: str(f.type) for f in fields(ShadingSettings) if f.name not in ("model", "color")}


@dataclass(frozen=True)
class RenderSettings:
    """Everything the strand renderer needs besides the scene (camera, lights, groom, head)."""

    size: tuple[int, int] = setting((320, 240), lo=8, hi=8192, unit="px", panel=False, reason="the window sets it (mane render and reference: --size)",
        help="Output image (width, height), pixels.")
    # --- tessellation along the strand
    interpolation: str = setting("catmull_rom", choices=INTERPOLATIONS,
        help="""Curve through the guide points: "catmull_rom" (interpolates them, phantom end points),
        "bspline" (uniform cubic B-spline, approximating; passes through root and tip thanks to
        the phantom points) or "bezier" (the Vulkan hair work's cubic Bezier per segment, inner
        control points P_i + (P_{i+1} - P_{i-1})/6 and P_{i+1} - (P_{i+2} - P_i)/6: the Catmull-Rom
        curve itself in Bernstein form, evaluated by de Casteljau, so the same image).""")
    segments: int = setting(32, lo=1, hi=4096, slider=(1, 128),
        help="Rendered segments per strand (rounded up to a multiple of the guide's segments).")
    # --- distance LOD (Chen: segments; TressFX 4.1: density and width)
    lod: bool = setting(False,
        help="""Distance level of detail: between lod_start and lod_end (camera to strand root, m) the
        segments per strand fall to lod_segment_percent (fractional tessellation), the strand count
        to lod_percent (strands fade out one by one) and the width rises to lod_width_multiplier.""")
    lod_start: float = setting(1.0, lo=0.0, hi=1000000.0, unit="m", slider=(0.0, 20.0),
        help="Distance LOD: camera-to-root distance (m) where the level of detail starts to fall.")
    lod_end: float = setting(5.0, lo=0.0, hi=1000000.0, unit="m", slider=(0.0, 50.0),
        help="Distance LOD: distance (m) where it reaches its lowest level (lod_percent, lod_segment_percent, lod_width_multiplier); beyond lod_start.")
    lod_percent: float = setting(0.5, lo=0.0, hi=1.0, lo_open=True,
        help="Fraction of strands kept at lod_end and beyond (TressFX LODPercent).")
    lod_width_multiplier: float = setting(2.0, lo=0.0, hi=100.0, lo_open=True, slider=(0.1, 8.0),
        help="Strand width multiplier at lod_end (TressFX LODWidthMultiplier).")
    lod_segment_percent: float = setting(0.25, lo=0.0, hi=1.0, lo_open=True,
        help="Fraction of ``segments`` kept at lod_end (Chen's segment LOD).")
    lod_min_segments: int = setting(4, lo=1, hi=4096, slider=(1, 64),
        help="Fewest segments per strand the LOD goes down to.")
    lod_depth: float = setting(64.0, lo=0.0, hi=1000000.0, slider=(0.0, 256.0),
        help="""Coverage LOD (mane.render.coverage_lod): the mean number of strands allowed to overlap
        a pixel of the groom before strands are thinned. Each frame the groom's mean depth
        complexity D is estimated from its box, strand count, mean length and width as the
        camera sees them; past lod_depth only the first round(strands_per_guide * lod_depth / D)
        strands of each guide are expanded and drawn (in every pass, the shadow maps too), each
        widened by what was dropped, so that coverage and opacity stay the same in expectation,
        and where strands are thinned and look short, with fewer segments. The default (64) leaves the default scenes untouched (50k strands at 1920x1080: D = 16)
        and thins 1M strands there (D = 326) to a fifth. The compute rasteriser's deep opacity
        map thins again by how the light sees the kept strands (a texel wide at least): past
        2 lod_depth strands over a texel, every m-th strand, m = floor(D_light / lod_depth), at m
        times the opacity (coverage_lod.light_strand_step; the 50k-strand target frame's
        D_light = 29: untouched). 0: off. Single-strand interpolation with pipeline="compute"
        only (the map's stride: the compute rasteriser, every interpolation).""")
    # --- strand multiplication
    strands_per_guide: int = setting(16, lo=1, hi=4096, slider=(1, 128),
        help="""Rendered strands per guide (the guide itself is strand 0). Beyond 64 (the tessellation
        limit) a guide is drawn in more instances of 64 isolines.""")
    interpolation_mode: str = setting("single", choices=INTERPOLATION_MODES,
        help=""""single": clumps around one guide; "multi": every rendered strand is the barycentric
        blend of 3 guide curves plus its root offset (Woodhouse; weights from grooming's
        GuideWeights via ``Renderer.set_guide_weights``, else random barycentrics hashed per strand
        over each guide and its two nearest guides); "hybrid": "multi", except strands whose 3
        guides straddle a collider (``colliders``, else the default head's SDF) take the
        single-strand form around their heaviest guide.""")
    colliders: tuple = setting((), each=6, unit="m",
        help="""Hybrid interpolation's colliders: ellipsoids (cx, cy, cz, rx, ry, rz) in metres (a sphere
        has rx = ry = rz). Empty: the default head's distance field when the head is the default.""")
    hybrid_margin: float = setting(0.002, lo=0.0, hi=1.0, unit="m", slider=(0.0, 0.02),
        help="""A straight segment between guide points straddles a collider when it passes deeper than
        this (m) inside it (roots sit on the scalp: chords between them dip a little inside).""")
    clump_radius: float = setting(0.006, lo=0.0, hi=1.0, unit="m", slider=(0.0, 0.05),
        help="Radius (m) of the disc, perpendicular to the guide, on which a clump's strands sit.")
    clump_root: float = setting(0.25, lo=0.0, hi=10.0, slider=(0.0, 2.0),
        help="Clump radius at the root, as a fraction of clump_radius (root taper).")
    clump_tip: float = setting(0.5, lo=0.0, hi=10.0, slider=(0.0, 2.0),
        help="Clump radius at the tip, as a fraction of clump_radius (tip taper; <1 gathers tips).")
    stray_fraction: float = setting(0.5, lo=0.0, hi=1.0,
        help="""Probability that a rendered strand deviates from its clump (the Vulkan hair / Rapp 2014:
        0.5); a deviating strand takes one of five equiprobable shapes (mane.render.strand_math).""")
    stray_amount: float = setting(1.5, lo=0.0, hi=100.0, slider=(0.0, 4.0),
        help="""How far a deviating strand leaves the clump, in clump radii, at its most (the sharp
        exponential's tip).""")
    curl_radius: float = setting(0.0, lo=0.0, hi=1.0, unit="m", slider=(0.0, 0.02),
        help="""Render-time curl: radius (m) of a helix around each strand's curve (0: off). It grows
        from 0 at the root to full by 10% of the strand.""")
    curl_frequency: float = setting(6.0, lo=0.0, hi=1000.0, slider=(0.0, 20.0),
        help="Curl turns per strand, root to tip (each strand starts at its own hashed phase).")
    strand_spread: float = setting(5.0, lo=0.0, hi=90.0, unit="deg", slider=(0.0, 30.0),
        help="""RMS angle (degrees) by which each rendered strand's direction, as shaded, tilts from its
        curve's (random per strand, Rayleigh-distributed, in a random direction; the kept guide is
        not tilted): the strands of a clump then catch the highlight at different places instead of
        as one flat white patch. 0: the curves' own tangents.""")
    keep_guide: bool = setting(True,
        help="Render the guide itself as the clump's strand 0 (offset 0).")
    # --- geometry
    geometry: str = setting("ribbons", choices=GEOMETRIES,
        help='"ribbons": camera-facing quads from a geometry shader; "lines": GL_LINES.')
    pipeline: str = setting("compute", choices=PIPELINES,
        help="""How the strands reach the rasteriser: "compute" (a compute pass writes every rendered
        strand's tessellated points once per frame, shared by all passes, which draw them by
        vertex pulling: instanced strips, no tessellation or geometry stages; TressFX's way) or
        "tessellation" (isolines + geometry-shader ribbons in every pass). The hardware OIT methods
        always use "tessellation"; the distance LOD is expanded too (once per camera position).""")
    rasterizer: str = setting("auto", choices=RASTERIZERS,
        help="""Who turns the hair into pixels: "hardware" (the GPU's raster units: triangle strips,
        MSAA), "compute" (compute shaders scan-convert every segment into a per-sample visibility
        buffer, nearest segment by atomic min, coverage accumulated, then each pixel shaded once
        per visible segment: Unreal's and Frostbite's way for thin strands; ``msaa`` n becomes a
        ceil(sqrt(n))^2 grid of samples per pixel for the hair, the head keeps n-sample MSAA unless
        ``head_msaa`` is off) or "auto": "compute" on GPUs built for computing with few raster units
        (NVIDIA H100/H200/H800/A100/A800/GH200/B100/B200) and on CPU rasterisers (llvmpipe: the
        default frame at 960 x 540 in 0.54 s against the raster units' 13.6 s), else "hardware". Needs
        pipeline="compute"; of the OIT methods the A-buffer, K-buffer, DBK-buffer and ShortCut have
        compute forms (mane.render.oit.compute), sorted blending and random subsets draw by
        hardware.""")
    head_msaa: bool = setting(False,
        help="""With the compute rasteriser: draw the head with ``msaa`` samples (its silhouette
        antialiased) or with one (the default). On GPUs with few raster units (H100/H200 class,
        where "auto" picks the compute rasteriser) the multisampled head costs 1.8 ms a 1080p
        frame (its clear alone 1.6 ms), more than half the hair (docs/performance.md); the hair's
        own samples do not depend on it. The hardware rasteriser always draws the head with
        ``msaa`` samples.""")
    depth_prepass: bool = setting(True,
        help="""With MSAA: draw the hair's depth first (its coverage as a sample mask), then shade it with
        the depth test LEQUAL and no depth writes, so the hair BSDF runs once per pixel and visible
        strand instead of once per overlapping strand.""")
    width: float = setting(0.0006, lo=0.0, hi=0.1, unit="m", slider=(0.0, 0.003),
        help="Strand width (m) at the root (ribbons).")
    width_tip: float = setting(0.35, lo=0.0, hi=10.0, slider=(0.0, 1.0),
        help="Width at the tip as a fraction of the root width (taper).")
    min_pixel_width: float = setting(1.0, lo=0.0, hi=100.0, unit="px", slider=(0.0, 4.0),
        help="""Ribbons narrower than this (pixels) are drawn this wide with coverage alpha = true/shown
        width, so sub-pixel strands fade instead of flickering. 0 turns coverage alpha off.""")
    # --- shading and lights
    shading: str = setting("chiang", choices=tuple(MODELS),
        help="""Hair shading model name (mane.render.shading.ShadingSettings): "chiang" (Chiang et al.
        2016, pbrt's and Mitsuba's hair model, with dual scattering) by default.""")
    shading_options: dict = setting(factory=dict, keys="mane.render.settings:shading_option_names",
        help="""Other ShadingSettings fields (e.g. {"melanin": (0.3, 0.1), "multiple_scattering": "none",
        "roughness": 0.12}). Colour comes from melanin (default the "brown" preset,
        mane.render.shading.PRESETS).""")
    hair_color: tuple[float, float, float] | None = setting(None, length=3, lo=0.0, hi=1000.0,
        help="""None (melanin drives the colour), or a linear RGB colour that replaces melanin: an
        explicit opt-in (ShadingSettings.color).""")
    use_file_colors: bool = setting(True,
        help="""A groom that carries its own colours, widths or transparency (cyHair arrays, USD
        displayColor/widths, PLY properties...) renders with them (their mean colour, median root
        width and taper, mean opacity: mane.render.file_appearance) in place of hair_color, width,
        width_tip and oit_opacity; False: the scene's hair model decides.""")
    ambient: float = setting(0.12, lo=0.0, hi=100.0, slider=(0.0, 1.0),
        help="Ambient light (linear radiance, white) added to the hair and the head.")
    skin_color: tuple[float, float, float] = setting((0.5, 0.32, 0.24), lo=0.0, hi=1000.0,
        help="Linear RGB albedo of the head mesh (Lambert).")
    scalp_tint: float = setting(0.8, lo=0.0, hi=1.0, slider=(0.0, 1.0),
        help="""How far the scalp's albedo (the head's "scalp" vertex weight) is tinted from skin_color
        toward the hair's colour: the look of the undrawn hair covering a real scalp between the
        drawn strands. 0: the scalp is skin (what a path tracer of the drawn strands sees).""")
    skin_bounce: float = setting(1.0, lo=0.0, hi=100.0, slider=(0.0, 4.0),
        help="""Scale of the light the head's skin reflects onto the hair (one bounce of light 0: a
        reflective shadow map of the head gathered by every shaded hair point, scattered as the
        fibre scatters diffuse light; mane.render.passes.skin_bounce). 1: the physical amount
        (Lambertian skin_color); 0: off. Nothing without a drawn head (docs/quality.md, item (10)).""")
    root_darkening: float = setting(0.0, lo=0.0, hi=1.0, slider=(0.0, 1.0),
        help="""How much darker a strand's root is than the rest of it (the hair's radiance times
        1 - root_darkening at the root, rising smoothly to 1 by a quarter of the strand): a painted
        occlusion, for looks. 0 (the default): none; the shadows already darken the hair near the
        scalp, and against a path tracer 0.45 (the look until 2026-12-02) made the image worse
        (docs/quality.md, "The painted root darkening").""")
    background: tuple[float, float, float] = setting((0.16, 0.17, 0.19), lo=0.0, hi=1000.0,
        help="sRGB background colour in [0, 1].")
    draw_head: bool = setting(True,
        help="Draw the head mesh (False: the hair alone).")
    # --- shadows
    shadows: str = setting("deep_opacity", choices=SHADOWS,
        help=""""none", "shadow_map" (depth + PCF, hair and head cast), "deep_opacity" (Yuksel and
        Keyser: 3 opacity layers after the first hair depth z0, in one RGBA texture), "adsm"
        (TressFX's approximated deep shadow map), "opacity_maps" (Kim and Neumann: osm_slices
        slices in several render targets) or "density" (Woodhouse: a ray march through a 3D
        density texture). The head casts through its own shadow map with every method.""")
    shadow_lights: int = setting(4, lo=1, hi=4, panel=False, reason="the viewer's lights set it (their casts-shadows boxes)",
        help="""How many lights, from light 0, cast shadows (1..4; the default 4: every light of up to
        four; Chen's scene: 3 lights, 2 casting). Each has its own maps: a shadow map, and with
        "deep_opacity" a deep opacity map; with "adsm", "opacity_maps" or "density" the lights after
        light 0 use a shadow map (hair and head), at extra_shadow_map_size. A light that casts none
        lights every fibre through the volume: under the default key, fill and rim with the key
        alone casting, Sintel brown was 1.82x too bright against the path tracer.""")
    shadow_map_size: int = setting(1024, lo=16, hi=8192, unit="texels", slider=(64, 4096),
        help="""Shadow / opacity map resolution (texels per side); 128..2048 is the intended range. The
        default 1024 resolves clumps and the thicker single fibres of a head of hair (Sintel:
        0.2-0.6 mm strands, 0.47 mm texels): with pcf 1, strand_opacity 0.7 and ms_shadow_footprint 2
        the per-pixel error against the path tracer drops 0.451 -> 0.415 (Sintel brown) for 0.5 ms
        of the 50k-strand 1080p frame on an H200 (3.09 -> 3.56 ms; docs/quality.md, "Fibre-resolved
        direct shadows").""")
    extra_shadow_map_size: int = setting(256, lo=16, hi=8192, unit="texels", slider=(64, 4096),
        help="""The maps of the lights after light 0 (shadow_lights), texels a side; at most
        shadow_map_size. A fill or rim light's shadow darkens the volume more than it draws single
        fibres, so a coarse map serves, and its deep opacity map thins its strands by itself
        (coverage_lod.light_strand_step) where texels hold many.""")
    pcf: int = setting(1, lo=1, hi=9, unit="texels",
        help="""PCF kernel: a pcf x pcf texel box, bilinearly weighted ((pcf + 1)^2 taps; 1 = bilinear
        interpolation between the 4 nearest texels), for every shadow method's look-up of the
        hair's direct light (the skin's: head_pcf; the multiple scattering's with deep opacity
        maps: ms_shadow_footprint). The default 1 keeps the fibre-fine map's strand shadows. A
        compile-time constant: changing it recompiles.""")
    ms_smoothing: float = setting(0.003, lo=0.0, hi=0.05, unit="m", slider=(0.0, 0.01),
        help="""The multiply scattered light, smoothed over this width (a Gaussian's sigma, m) across
        the hair (passes/ms_smooth.py; both rasterisers, not the transparency methods): in the
        volume a fibre gathers scattered light from every direction, so what it sends on varies
        little from one fibre to the next, while dual scattering evaluated with each fibre's own
        tangent does (Sintel blond against the path tracer: 0.341 -> 0.276 relative error per
        pixel; docs/quality.md). 0: each fibre's own term.""")
    ms_shadow_footprint: int = setting(2, lo=0, hi=9, unit="texels",
        help="""Deep opacity maps only: the multiple-scattering term (dual scattering's fibre count and
        forward-scattered light) sees light 0's transmittance averaged over this many texels
        square (a box like pcf's), the direct light the pcf box's; 0: both see the pcf box's. With
        a fibre-resolving map (shadow_map_size 1024-2048, strand_opacity 0.7-1, pcf 1) the direct light
        gets strand-resolved shadows while the scattered light stays smooth (docs/quality.md,
        "Fibre-resolved direct shadows").""")
    head_pcf: int = setting(2, lo=1, hi=9, unit="texels",
        help="""The head's (skin's) PCF kernel, as ``pcf`` is the hair's. 1 (bilinear between the 4
        nearest texels) makes the head pass about 30% cheaper on an H200 but shows the shadow
        map's texels as steps along the jaw and neck (docs/performance.md, docs/quality.md).""")
    hair_shadow_lookup: str = setting("fragment", choices=SHADOW_LOOKUPS,
        help="""Where the hardware rasteriser's hair looks up its shadows: "fragment" (every pixel of every
        strand) or "vertex" (at the strands' points, interpolated along each segment: a shadow's
        edge across a strand is as sharp as its segments, not the map's texels). Cheaper where
        fragments cost (a CPU rasteriser: the software preset); the compute rasteriser always looks
        up per sample, the head always per fragment.""")
    shadow_bias: float = setting(3.0, lo=0.0, hi=100.0, unit="texels", slider=(0.0, 10.0),
        help="Depth bias, in shadow-map texels (world size of a texel).")
    shadow_normal_offset: float = setting(1.5, lo=0.0, hi=100.0, unit="texels", slider=(0.0, 10.0),
        help="""Surfaces receiving shadows (the head): the shadow look-up point moves off the surface
        along its normal by this many texels of the map, times sin(angle between normal and light).""")
    shadow_slope_bias: float = setting(1.5, lo=0.0, hi=100.0, unit="texels", slider=(0.0, 10.0),
        help="""Surfaces receiving shadows (the head): more depth bias, in texels per unit of
        tan(angle between normal and light) (up to 10), against acne and banding at grazing light.""")
    dom_layers: tuple[float, float, float] = setting((0.05, 0.15, 1.0), lo=0.0, lo_open=True, hi=100.0,
        help="Deep opacity layer ends after z0, as fractions of the hair's depth extent seen from the light.")
    strand_opacity: float = setting(0.7, lo=0.0, hi=100.0, slider=(0.0, 1.0),
        help="""Opacity one strand adds in the deep opacity map (per covered texel): a fibre crossed
        passes exp(-shadow_density * strand_opacity) of the light (the default: 0.12, nearly
        opaque: the direct light's strand shadows; the light through the fibres is the
        multiple-scattering term's, ms_shadow_footprint).""")
    shadow_density: float = setting(3.0, lo=0.0, hi=1000.0, slider=(0.0, 10.0),
        help="""Scale of the opacity -> transmittance exponent: T = exp(-density * O). Every method uses
        it: one strand crossed passes exp(-shadow_density * strand_opacity) of the light.""")
    adsm_spacing: float = setting(10.0, lo=0.0, lo_open=True, hi=10000.0, slider=(0.5, 50.0),
        help="""ADSM (TressFX's approximated deep shadow map, shadows="adsm"): the fibre spacing along
        the light, in strand widths; n = (depth behind the first hair occluder) / (adsm_spacing *
        width) strands are assumed crossed, T = (1 - alpha)^n with 1 - alpha = exp(-shadow_density *
        strand_opacity). Smaller = darker (Hunz §4).""")
    osm_slices: int = setting(16, lo=4, hi=32, multiple_of=4,
        help="""Opacity shadow maps (shadows="opacity_maps"): uniform slices between the hair's nearest
        and farthest light depth; 4 per RGBA32F target, 4..32 (8 render targets).""")
    density_resolution: int = setting(64, lo=16, hi=256,
        help="""Density ray march (shadows="density"): nodes per side of the 3D density texture built
        from the rendered strands (16..256). With density_source="simulator" the simulator's
        friction grid (its own resolution) is used instead.""")
    density_source: str = setting("auto", choices=DENSITY_SOURCES,
        help=""""strands": splat the rendered strands (tessellated, clumped) into the 3D texture every
        frame; "simulator": the simulator's hair-hair friction grid (guide particles, scaled to
        the rendered strands); "auto": the simulator's grid when the strands come from a
        simulator whose grid has been built, otherwise the strands.""")
    density_step: float = setting(0.5, lo=0.05, hi=4.0, unit="cells",
        help="Ray-march step, in grid cells.")
    # --- anti-aliasing and output
    msaa: int = setting(4, choices=(1, 2, 4, 8, 16),
        help="Samples per pixel (1, 2, 4, 8, 16; clamped to GL_MAX_SAMPLES).")
    supersample: int = setting(1, choices=(1, 2),
        help="1, or 2: render at twice the size per axis and resolve with Chen's 5-tap filter.")
    accumulate: int = setting(16, lo=1, hi=1024, slider=(1, 64), unit="frames",
        help="""Frames a still picture averages: while the camera, lights, hair, head and settings
        stay the same, each frame after the first is drawn with the image moved by a new sub-pixel
        offset and folded into a mean, which the output shows, up to this many frames (16 at msaa 4:
        64 samples a pixel, spread over the pixel as a path tracer's). ``Renderer.render_still``
        draws what the mean still needs. A moving scene (a simulation) draws every frame at the
        pixel centres as without it; 1: off.""")
    still_shadow_map_size: int = setting(2048, lo=0, hi=8192, unit="texels",
        help="""The shadow and opacity maps of a still picture's frames in its mean (``accumulate``):
        this many texels a side, with ``still_dom_layers``. Drawn once for the picture while the
        scene is still (mane.render.light_key), a finer map resolves the fibres' own shadows
        (Sintel brown against the path tracer 0.330 -> 0.299 relative error per pixel,
        docs/quality.md), which every frame could not afford (the 100k close-up's 4 ms). 0, or
        no more than shadow_map_size: the frames' own maps. Lowered to what the GPU's storage
        blocks and textures hold; the frames' own where they do not fit its memory.""")
    still_extra_shadow_map_size: int = setting(1024, lo=0, hi=8192, unit="texels",
        help="""The extra lights' maps (extra_shadow_map_size) in a still picture's frames: with 256
        under the default key, fill and rim, Sintel blond came out 1.07x bright with a crown to lower
        falloff 0.69x the path tracer's, with 1024 0.97x and 0.82x (docs/quality.md). 0, or no more
        than extra_shadow_map_size: the frames' own. At most the still picture's light 0 map.""")
    still_segments: int = setting(128, lo=0, hi=4096, slider=(0, 256),
        help="""Rendered segments per strand of a still picture's frames in its mean (as segments): a
        curl's chords between the expanded points lie up to a strand's width inside the curve
        (the curly head at 32 segments: 0.28 px median, 0.6 px at the 90th percentile, against
        strands 0.27 px wide), and a still picture can afford more segments (the curly head
        against the path tracer 0.48 -> 0.42 relative error per pixel at 64, against a reference
        drawn through the still picture's own points 0.366 -> 0.341 from 64 to 128, 0.337 at 256;
        docs/quality.md). 0, or no more than segments: the frames' own. The path tracer's
        reference draws these points too (mane.reference.renderer_strands).""")
    still_dom_layers: tuple[float, float, float] = setting((0.02, 0.06, 1.0), lo=0.0, lo_open=True, hi=100.0,
        help="""The deep opacity layers' ends of those maps (as dom_layers): the first closer to the
        lit surface, where most of a fibre's shadow falls.""")
    still_near_field: bool = setting(True,
        help="""A still picture's frames in its mean shade Chiang's fibre with its near field
        (``shading_options`` near_field, mane.render.shading.ShadingSettings): a fibre wider than a
        pixel shows in each pixel the part of its width the pixel covers, its highlights where the
        path tracer puts them (a close-up of the curly head, fibres ~3 px: 0.84 -> 0.76 relative
        error per pixel; docs/quality.md), which the frames leave off for their cost. Fibres under
        a pixel look the same either way. False: the frames' own setting.""")
    tone_mapping: str = setting("aces", choices=TONE_MAPS,
        help='Tone curve from linear radiance to the display: "aces" (the ACES filmic fit), "reinhard" or "none" (clamp).')
    exposure: float = setting(1.0, lo=0.0, hi=1000.0, slider=(0.0, 4.0),
        help="Radiance multiplier before tone mapping.")
    # --- order-independent transparency (mane.render.oit)
    oit: str = setting("none", choices=OIT_METHODS,
        help="""Hair transparency: "none" (depth-tested premultiplied blending, or a coverage sample mask
        with MSAA), "sorted_blending" (guide segments sorted by view depth on the GPU, blended back to
        front), "random_subsets" (oit_k subsets, the nearest fragment of each, sorted per pixel),
        "a_buffer" (per-pixel linked lists of every fragment), "k_buffer" (the oit_k nearest per
        pixel), "dbk_buffer" (Hunz's depth-bounded lists over an opaque layer) or "shortcut"
        (TressFX: the 3 nearest plus the total transmittance). Any method but "none" renders
        single-sampled (the hair's own coverage alpha anti-aliases it).""")
    oit_k: int = setting(8, lo=0, hi=64,
        help="""Fragments sorted per pixel: the A-buffer's and DBK-buffer's resolve (0: all of them),
        the K-buffer's slots, the number of random subsets. The rest of a list is blended
        unsorted behind the k nearest.""")
    oit_opacity: float = setting(1.0, lo=0.0, lo_open=True, hi=1.0,
        help="""Strand opacity in the camera view for the OIT methods (Hunz's alpha_s), times the
        coverage alpha; 1 keeps the coverage alpha alone.""")
    oit_nodes_per_pixel: float = setting(8.0, lo=0.05, hi=1024.0, slider=(0.5, 64.0),
        help="""First size of the A-buffer / DBK-buffer node pool, in nodes per pixel; it grows (to what
        the frame needed, plus a quarter) after a frame that overflowed.""")
    oit_max_bytes: int = setting(0, lo=0, hi=1099511627776, unit="bytes",
        help="Upper bound on the node pool, bytes (0: what the GPU allows).")
    oit_auto_shift: bool = setting(True,
        help="""DBK-buffer: choose the layer's depth shift every frame from the previous frame's
        fragment depths, so that the layer reaches where the transmittance falls below
        oit_threshold (about k = log(oit_threshold) / log(1 - alpha) fragments).""")
    oit_depth_shift: float = setting(0.02, lo=0.0, lo_open=True, hi=100.0, unit="m", slider=(0.001, 0.2),
        help="""DBK-buffer: the layer's depth (m) behind the nearest hair when oit_auto_shift is off
        (and the first frame's guess when it is on).""")
    oit_threshold: float = setting(0.02, lo=0.0, hi=1.0, lo_open=True, hi_open=True,
        help="DBK-buffer automatic shift: the transmittance the layer should reach.")
    oit_shift_quantile: float = setting(0.95, lo=0.0, hi=1.0, lo_open=True,
        help="""DBK-buffer automatic shift: the fraction of hair pixels whose layer reaches that
        transmittance (the shift is this quantile of the per-pixel depths needed).""")
    oit_dbk_behind: str = setting("blend", choices=("opaque", "blend"),
        help="""DBK-buffer: the hair behind the layer is drawn "opaque" (Hunz) or "blend"-ed with its
        alpha (depth-tested, unsorted) before the layer's lists are blended over it.""")
    oit_kbuffer: str = setting("auto", choices=KBUFFER_MODES,
        help="""K-buffer insertion: "atomic32" (two geometry passes: 32-bit depth keys kept by atomicMin
        bubbling, then the colours of the kept keys), "atomic64" (one pass: 64-bit depth|colour
        keys, GL_NV_shader_atomic_int64), "interlock" (one pass: fragment shader interlock) or
        "auto" (atomic64, else interlock, else atomic32).""")

    def __post_init__(self) -> None:
        validate(self)   # every field against its declaration (mane.setting); then what ties fields together
        for name in ("dom_layers", "still_dom_layers"):
            layers = getattr(self, name)
            if not (layers[0] < layers[1] < layers[2]):
                raise UsageError(f"{name} must be 3 increasing positive fractions, got {layers}")
        if self.lod and not self.lod_end > self.lod_start:
            raise UsageError(f"lod_end must be beyond lod_start, got {self.lod_start}..{self.lod_end}")
        if any(min(c[3:]) <= 0 for c in self.colliders):
            raise UsageError(f"colliders are ellipsoids (cx, cy, cz, rx, ry, rz) with positive radii, "
                             f"got {self.colliders}")
        if self.oit in ("k_buffer", "random_subsets") and self.oit_k < 1:
            raise UsageError(f"oit_k must be in 1..64 for the K-buffer and random subsets, got {self.oit_k}")

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
