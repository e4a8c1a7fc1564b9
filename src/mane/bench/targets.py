"""The targets of ``mane bench``: name -> (module, one-line help). A target module has
``run(ctx, mode, progress=None) -> dict`` and ``format_text(result) -> str`` (``all`` and
``quality`` also ``run_cli(args)``: they write a folder)."""
from __future__ import annotations

# target -> (module, one-line help)
TARGETS: dict[str, tuple[str, str]] = {
    "sim": ("mane.bench.sim_bench", "strand solver: GPU ms per pass and per step, grids, FLIP, bandwidth"),
    "render": ("mane.bench.render_bench", "strand renderer: GPU ms per pass and per frame; the seeds' sweeps "
                                          "(strands x shading, shadows x map x PCF, guides, divisions, LOD, MSAA)"),
    "oit": ("mane.bench.oit_bench", "hair transparency: GPU ms and bytes per OIT method x shadow method x "
                                    "viewport x groom (Hunz Figs. 41-42); the DBK-buffer target"),
    "quality": ("mane.bench.quality", "validation figures: shading GLSL vs equations, shadows vs an exact ray cast, "
                                      "OIT vs the exact sort, simulation invariants (--out DIR: quality.json + images)"),
    "limits": ("mane.bench.limits", "the GPU's measured limits: DRAM copy bandwidth, raster units' peak (triangles "
                                    "and samples per second, 1x and 4x MSAA), atomicMin throughput (32/64-bit)"),
    "fidelity": ("mane.bench.fidelity", "every shading model and shadow method against a path-traced reference "
                                        "(Mitsuba 3, the reference extra): luminance, colour, falloff, MAE, FLIP "
                                        "(--out DIR: fidelity.json + side-by-side images)"),
    "dataset": ("mane.bench.dataset_bench", "mane dataset's pipeline: samples per second (default 512x512, every map, "
                                            "50k strands) and where the time goes (GPU, read-back, encoding, writing)"),
    "all": ("mane.bench.all_bench", "every target in turn (--out DIR: JSON, CSV per table, plots/*.png beside the "
                                    "seeds' published figures, summary.md; --only, --baseline)"),
}
