"""The seeds' published performance numbers, as data, for the plots and tables of ``mane bench all``.

Every value comes from the research digests ``../shared/research/seed-*.md`` (paths relative to
the repository, beside it as ``../shared/data`` is; section 2 of each), which copy the theses'
tables and text. Each ``Point`` carries its source; values the
digest marks as derived (e.g. ms computed from a published FPS) or read by eye from a chart
say so (``derived`` / ``approx``), and the plot labels repeat it. Values a digest reports as
garbled or missing are left out (the ``omitted`` notes say which), never guessed.

    fig = FIGURES["vulkan_guides"]
    fig.hardware, fig.unit, [(p.x, p.y) for p in fig.points]
"""
from __future__ import annotations

from dataclasses import dataclass

DIGESTS = {
    "woodhouse": "../shared/research/seed-000-woodhouse.md §2",
    "chen": "../shared/research/seed-001-chen.md §2",
    "hunz": "../shared/research/seed-002-hunz.md §2",
    "vulkan": "../shared/research/seed-003-vulkan.md §2",
}


@dataclass(frozen=True)
class Point:
    """One published value. ``x``: the figure's x (a number or a category); ``series``: the
    line or bar group it belongs to; ``source``: table / figure / text it is taken from."""

    x: object
    y: float
    series: str
    source: str
    approx: bool = False      # read by eye from a chart (the digest's "approximate" readings)
                              # (a value the source itself gives as approximate says so in ``note``)
    derived: bool = False     # computed from published numbers (by the digest's extractor)
    note: str = ""


@dataclass(frozen=True)
class Figure:
    key: str
    title: str
    seed: str
    hardware: str
    unit: str
    points: tuple = ()
    note: str = ""
    omitted: tuple = ()        # published values left out, and why
    digest: str = ""

    def series(self) -> dict:
        out: dict[str, list[Point]] = {}
        for p in self.points:
            out.setdefault(p.series, []).append(p)
        return out

    def label(self, series: str | None = None) -> str:
        """Legend text: seed, series, hardware, and "read by eye" / "derived" where it applies."""
        pts = [p for p in self.points if series is None or p.series == series]
        tags = []
        if any(p.approx for p in pts):
            tags.append("values read by eye from the chart")
        if any(p.derived for p in pts):
            tags.append("derived from published values")
        name = f"{self.seed}" + (f" {series}" if series else "")
        return f"{name} ({self.hardware}" + ("; " + "; ".join(tags) if tags else "") + ")"


def _pts(series: str, source: str, pairs, **kw) -> tuple:
    return tuple(Point(x, y, series, source, **kw) for x, y in pairs)


# --------------------------------------------------------------------------- Woodhouse 2017
WOODHOUSE_HW = {"7520G": "AMD Radeon HD 7520G (laptop, shared DDR3)",
                "6670": "AMD Radeon HD 6670 (desktop, DDR3)"}
_W51 = "Woodhouse 2017 Table 5.1 (ms; transparency off, AA on)"
_W52 = "Woodhouse 2017 Table 5.2 (ms; Draw and Total with AA / without AA)"

WOODHOUSE_T51 = Figure(
    key="woodhouse_t51", title="Woodhouse Table 5.1: simulation / rendering ms", seed="Woodhouse 2017",
    hardware="AMD HD 7520G and HD 6670", unit="ms",
    points=(
        # (method, GPU) -> simulation, rendering
        *_pts("sim 7520G", _W51, [("TressFX 2.0", 17.15), ("gpu", 6.84), ("optimised_gpu", 0.93)]),
        *_pts("sim 6670", _W51, [("TressFX 2.0", 9.21), ("gpu", 4.94), ("optimised_gpu", 0.65)]),
        *_pts("render 7520G", _W51, [("TressFX 2.0", 28.20), ("gpu", 38.46), ("optimised_gpu", 16.55)]),
        *_pts("render 6670", _W51, [("TressFX 2.0", 11.05), ("gpu", 15.57), ("optimised_gpu", 8.83)]),
        *_pts("total 7520G", _W51, [("TressFX 2.0", 45.35), ("gpu", 45.30), ("optimised_gpu", 17.49)]),
        *_pts("total 6670", _W51, [("TressFX 2.0", 20.26), ("gpu", 20.52), ("optimised_gpu", 9.47)]),
    ),
    note="242 simulated strands x 8 particles smoothed to 16 vertices; rendered strand count and "
         "resolution not stated.",
    digest=DIGESTS["woodhouse"])

WOODHOUSE_T52 = Figure(
    key="woodhouse_t52", title="Woodhouse Table 5.2: ms per component", seed="Woodhouse 2017",
    hardware="AMD HD 7520G and HD 6670", unit="ms",
    points=(
        *_pts("gpu 7520G", _W52, [("strand dynamics", 1.04), ("clear voxels", 0.47), ("voxel calculations", 5.28),
                                  ("draw msaa 4", 38.46), ("draw msaa 1", 26.27)]),
        *_pts("gpu 6670", _W52, [("strand dynamics", 0.43), ("clear voxels", 0.15), ("voxel calculations", 4.36),
                                 ("draw msaa 4", 15.57), ("draw msaa 1", 10.58)]),
        *_pts("optimised_gpu 7520G", _W52, [("strand dynamics", 0.12), ("clear voxels", 0.31),
                                            ("voxel calculations", 0.40), ("draw msaa 4", 16.55),
                                            ("draw msaa 1", 8.16)]),
        *_pts("optimised_gpu 6670", _W52, [("strand dynamics", 0.12), ("clear voxels", 0.28),
                                           ("voxel calculations", 0.22), ("draw msaa 4", 8.83),
                                           ("draw msaa 1", 4.38)]),
    ),
    note="His 'gpu' version renders deep opacity maps, 'optimised_gpu' density shadows; 'draw msaa 4/1' are "
         "Table 5.2's Draw with AA / without AA.",
    digest=DIGESTS["woodhouse"])

# --------------------------------------------------------------------------- Chen 2011
CHEN_HW_SIM = "GeForce 9600GT (simulation), Intel i7-930 (CPU)"
CHEN_HW_RENDER = "GeForce GTX 480 (rendering), 9600GT (simulation)"

CHEN_T2 = Figure(
    key="chen_t2", title="Chen Table 2: FLIP grid cells vs FPS", seed="Chen 2011", hardware=CHEN_HW_SIM,
    unit="fps",
    points=(
        *_pts("CPU", "Chen 2011 Table 2 (FPS, CPU: MIC-preconditioned PCG)", [(16, 21.8), (32, 13.3), (64, 3.19)]),
        *_pts("GPU", "Chen 2011 Table 2 (FPS, GPU: Jacobi-preconditioned PCG)", [(16, 96.2), (32, 86.5), (64, 37.7)]),
    ),
    note="FPS of his whole simulation with the volume method; CPU and GPU differ in the PCG preconditioner.",
    digest=DIGESTS["chen"])

CHEN_T2_SPEEDUP = Figure(
    key="chen_t2_speedup", title="Chen Table 2: GPU speed-up over the CPU", seed="Chen 2011", hardware=CHEN_HW_SIM,
    unit="x",
    points=(
        Point(16, 96.2 / 21.8, "speed-up", "Chen 2011 Table 2: printed '.4x' (truncated in the extraction); "
              "96.2 / 21.8 = 4.4x from the table's FPS", derived=True),
        Point(32, 6.5, "speed-up", "Chen 2011 Table 2"),
        Point(64, 11.8, "speed-up", "Chen 2011 Table 2"),
    ),
    digest=DIGESTS["chen"])

_C4 = "Chen 2011 Table 4 (computation time percentage in one time step)"
CHEN_T4 = Figure(
    key="chen_t4", title="Chen Table 4: share of a simulation step", seed="Chen 2011", hardware=CHEN_HW_SIM,
    unit="%",
    points=(
        *_pts("CPU", _C4, [("solving_constraints", 31.4), ("volume_method", 65.7), ("force_velocity_position", 2.9)]),
        *_pts("GPU", _C4, [("solving_constraints", 19.4), ("volume_method", 76.6), ("force_velocity_position", 4.0)]),
    ),
    note="grid 32^3 in his demo scene (1750 key hairs x 6 particles, 20 constraint iterations).",
    digest=DIGESTS["chen"])

_C5 = "Chen 2011 Table 5 (FPS vs viewing distance with LOD; distance units not given)"
CHEN_T5 = Figure(
    key="chen_t5", title="Chen Table 5: FPS vs viewing distance (LOD)", seed="Chen 2011", hardware=CHEN_HW_RENDER,
    unit="fps",
    points=(
        *_pts("800x600", _C5, [(0.2, 25), (0.4, 44), (0.6, 63), (1.0, 98), (1.5, 136.1), (3.0, 136.1)]),
        *_pts("1024x712", _C5, [(0.2, 20.6), (0.4, 40.2), (0.6, 59.6), (1.0, 93.2), (1.5, 136.1), (3.0, 136.1)]),
        *_pts("1152x802", _C5, [(0.2, 18.3), (0.4, 36.9), (0.6, 56.1), (1.0, 88.7), (1.5, 136.1), (3.0, 136.1)]),
        *_pts("1280x968", _C5, [(0.2, 15.9), (0.4, 31.9), (0.6, 50.9), (1.0, 83.2)]),
    ),
    note="FPS plateaus at 136.1 where his simulation is the bottleneck; 28,000 hairs x 20 segments, DOM.",
    omitted=("1280x968 at 1.5: printed '36.' (truncated in the extraction, likely 136.1), left out",
             "1280x968 at 3.0: blank in the extraction, left out"),
    digest=DIGESTS["chen"])

# --------------------------------------------------------------------------- Hunz 2016
HUNZ_HW = "GeForce GTX 960, 656x861"

HUNZ_F33 = Figure(
    key="hunz_f33", title="Hunz Fig. 33: ms vs strand count per shading model", seed="Hunz 2016", hardware=HUNZ_HW,
    unit="ms", points=(),
    note="Fig. 33's values appear only in the chart (no ms in the text); the models 'all perform very "
         "similarly'. Nothing is plotted for it.",
    digest=DIGESTS["hunz"])

_H36 = "Hunz 2016 §6.2 text beside Fig. 36 (50k strands, 656x861)"
HUNZ_F36 = Figure(
    key="hunz_f36", title="Hunz Fig. 36: shadow method x map size x PCF", seed="Hunz 2016", hardware=HUNZ_HW,
    unit="ms",
    points=(
        Point(256, 6.3, "deep_opacity pcf 3x3", _H36 + ": DOM ~6.3 ms at 256^2, 3x3 PCF",
              note="approximate in the thesis' own text"),
        Point(256, 3.3, "adsm pcf 3x3", _H36 + ": ADSM ~3.3 ms at 256^2, 3x3 PCF",
              note="approximate in the thesis' own text"),
    ),
    note="The chart's other values are not in the text. Also stated: at 512^2 with high PCF ADSM is only ~5% "
         "slower than SM; map resolution is DOM's biggest cost.",
    digest=DIGESTS["hunz"])

_H41 = "Hunz 2016 text beside Fig. 41 (FPS; ms = 1000 / FPS computed by the digest)"
HUNZ_F41 = Figure(
    key="hunz_f41", title="Hunz Fig. 41: OIT method x shadow method", seed="Hunz 2016", hardware=HUNZ_HW,
    unit="ms",
    points=(
        Point("dbk_buffer", 20.0, "deep_opacity", _H41 + ": DBK-buffer with DOM, 3x3 PCF, 'a minimum of 50' FPS",
              derived=True),
        Point("dbk_buffer", 1000 / 58, "adsm", _H41 + ": DBK-buffer with ADSM 'nearly 58' FPS", derived=True),
        Point("random_subsets", 1000 / 91, "deep_opacity", _H41 + ": random subsets (k = 8) with DOM 91 FPS",
              derived=True),
        Point("random_subsets", 8.0, "adsm", _H41 + ": random subsets (k = 8) with ADSM 125 FPS", derived=True),
    ),
    note="Straight model (50,000 strands) seen from the side; the chart's other bars are not in the text.",
    digest=DIGESTS["hunz"])

_H42 = "Hunz 2016 Fig. 42 and text (his 'MB' are MiB)"
HUNZ_F42 = Figure(
    key="hunz_f42", title="Hunz Fig. 42: OIT memory", seed="Hunz 2016", hardware="656x861 viewport", unit="MiB",
    points=(
        Point("random_subsets", 34.47, "656x861", _H42 + ": k = 8 RGBA16 targets (16-bit depth not counted)"),
        Point("k_buffer", 36.63, "656x861", _H42 + ": K+-buffer, k = 8 RGBA16 + 4 B counter per pixel"),
        Point("a_buffer", 150.46, "656x861", _H42 + ": 12,959,208 fragments + 2.16 MB heads"),
        Point("dbk_buffer", 59.25, "656x861", _H42 + ": PPLL 53.86 (4,518,344 fragments) + opaque layer"),
        Point("tressfx_a_buffer", 276.0, "656x861", _H42 + ": TressFX A-buffer preallocated at this viewport, "
              "'~276 MB'", note="approximate in the thesis' own text"),
        Point("tressfx_a_buffer", 930.0, "1920x1080", _H42 + ": TressFX A-buffer at 1920x1080, 930 MB"),
    ),
    digest=DIGESTS["hunz"])

# --------------------------------------------------------------------------- Vulkan hair (2019)
VULKAN_HW = "RTX 2080, i9-9900K"
_V = "Realtime Vulkan Hair (2019) chart {}: FPS read by eye by the digest (approximate)"

VULKAN_GUIDES = Figure(
    key="vulkan_guides", title="Vulkan: FPS vs guide strands", seed="Vulkan hair 2019", hardware=VULKAN_HW,
    unit="fps",
    points=_pts("fps", _V.format("performanceNumStrands.png"),
                [(100, 1840), (1000, 550), (2000, 310), (3000, 200), (4000, 160), (5000, 135)], approx=True),
    note="x: 'Number of Strands' (guides); shipped configuration 900 guides x 12 strands, 42 segments.",
    digest=DIGESTS["vulkan"])

VULKAN_DIVISIONS = Figure(
    key="vulkan_divisions", title="Vulkan: FPS vs tessellation divisions", seed="Vulkan hair 2019",
    hardware=VULKAN_HW, unit="fps",
    points=_pts("fps", _V.format("performanceDivisions.png"), [(10, 1000), (20, 790), (40, 600), (60, 420)],
                approx=True),
    note="flat at ~420 FPS from about 60-70 to 100 divisions (the digest's reading).",
    digest=DIGESTS["vulkan"])

VULKAN_SPG = Figure(
    key="vulkan_strands_per_guide", title="Vulkan: FPS vs strands per guide", seed="Vulkan hair 2019",
    hardware=VULKAN_HW, unit="fps",
    points=_pts("fps", _V.format("performanceNumTessellated.png"),
                [(1, 1730), (10, 620), (20, 360), (30, 255), (40, 195), (50, 150)], approx=True),
    digest=DIGESTS["vulkan"])

VULKAN_PCF = Figure(
    key="vulkan_pcf", title="Vulkan: FPS vs shadow-map samples per pixel", seed="Vulkan hair 2019",
    hardware=VULKAN_HW, unit="fps",
    points=_pts("fps", _V.format("performanceShadowSamples.png"),
                [(1, 590), (4, 545), (8, 505), (12, 420), (16, 310)], approx=True),
    digest=DIGESTS["vulkan"])

FIGURES: dict[str, Figure] = {f.key: f for f in (
    WOODHOUSE_T51, WOODHOUSE_T52, CHEN_T2, CHEN_T2_SPEEDUP, CHEN_T4, CHEN_T5, HUNZ_F33, HUNZ_F36, HUNZ_F41,
    HUNZ_F42, VULKAN_GUIDES, VULKAN_DIVISIONS, VULKAN_SPG, VULKAN_PCF)}


def as_dict() -> dict:
    """Every figure as plain JSON data (for DIR/seed_figures.json)."""
    out = {}
    for k, f in FIGURES.items():
        out[k] = {"title": f.title, "seed": f.seed, "hardware": f.hardware, "unit": f.unit, "note": f.note,
                  "omitted": list(f.omitted), "digest": f.digest,
                  "points": [{"x": p.x, "y": p.y, "series": p.series, "source": p.source, "approx": p.approx,
                              "derived": p.derived, **({"note": p.note} if p.note else {})} for p in f.points]}
    return out


__all__ = ["Point", "Figure", "FIGURES", "DIGESTS", "as_dict", "WOODHOUSE_T51", "WOODHOUSE_T52", "CHEN_T2",
           "CHEN_T2_SPEEDUP", "CHEN_T4", "CHEN_T5", "HUNZ_F33", "HUNZ_F36", "HUNZ_F41", "HUNZ_F42", "VULKAN_GUIDES",
           "VULKAN_DIVISIONS", "VULKAN_SPG", "VULKAN_PCF"]
