"""``mane bench limits``: what this GPU can do at most, measured by micro-benchmarks, and how far
each stage of mane is from it (issue 7: "each stage's distance from its hardware limit").

    result = run(ctx, "quick")              # the JSON object (limits.json in ``mane bench all``)
    peaks = result["peaks"]                 # the measured limits, in one place
    rows = distance_rows(all_results)       # {"sim": .., "render": .., "limits": ..} -> fractions

Sections (``bench`` in each row); every row says its unit and how it was measured:

``dram``
    A streaming copy (``mane/gpu/limits_copy.comp``: one uvec4 a thread, coalesced) between two
    buffers much larger than the L2 (GPU: 256 MiB quick, 1 GiB default, 1.5 GiB full; software
    renderers: 8-64 MiB). GB/s = (bytes read + bytes written) / time, the way the simulator's
    integrate bandwidth is counted (``sim_bench.integrate_bytes``).
``raster``
    The raster units' peak on hair-like geometry (``mane/gpu/limits_raster.vert`` / ``.frag``):
    strips of 32 quads 4 x 1 pixels, one instance per strip, drawn as triangle strips with vertex
    pulling (as ``hair_pull.vert`` draws a strand), so every triangle covers 2 pixels; they tile the
    target pixel-aligned, ``layers`` times over, with a trivial fragment shader, no depth test, no
    blending, into an RGBA16F target (the renderer's HDR format) with 4x MSAA and with 1 sample.
    Triangles/s, samples/s (a ``GL_SAMPLES_PASSED`` query counts the samples written) and pixels/s
    (fragment shader invocations: the pixels covered).
``atomics``
    ``atomicMin`` throughput (``mane/gpu/limits_atomic.comp``) into a buffer of 1920 x 1080 x 4
    words (the compute rasteriser's per-sample visibility buffer at the target's size): 32-bit, and
    64-bit where ``GL_NV_shader_atomic_int64`` exists; every operation at a random word (the limit),
    and each thread's operations at consecutive words (a thread walking a segment's samples, as
    ``hair_raster.comp`` does: more local than random, so the rasteriser may beat the random
    figure).

Each measurement: one untimed run (compiles, touches the memory), then ``reps`` runs, each a
section of ``mane.gpu.profiler.GpuProfiler`` (GL_TIMESTAMP pairs on GPUs; on software renderers
CPU wall time between two ``ctx.finish()``). A row's ``value`` is from the fastest run (the
limit), ``value_median`` from the median one. The kernels, draws and their shaders are in
``mane.gpu.microbench``; this module times them and writes the rows.
"""
from __future__ import annotations

import time

from .common import BenchRows, Skip, check_sections, envelope, failures_table, fmt, peak_bandwidth, stats, table, title_line

SAMPLE_GRID_WORDS = 1920 * 1080 * 4        # the compute rasteriser's 4x sample grid at 1920x1080
STRIP_SEGMENTS, SEG_PX, WIDTH_PX = 32, 4.0, 1.0   # a strip: 32 quads of 4 x 1 pixels (2 px triangles)

# "gpu": hardware; "software": llvmpipe and the like (seconds in all)
MODE_CONFIG = {
    "quick": {
        "gpu": dict(reps=5, copy_mib=256, raster_size=(1920, 1080), raster_layers=4,
                    atomic_threads=1 << 18, atomic_ops=64),
        "software": dict(reps=3, copy_mib=8, raster_size=(320, 240), raster_layers=1,
                         atomic_threads=1 << 13, atomic_ops=16),
    },
    "default": {
        "gpu": dict(reps=20, copy_mib=1024, raster_size=(1920, 1080), raster_layers=16,
                    atomic_threads=1 << 20, atomic_ops=64),
        "software": dict(reps=5, copy_mib=32, raster_size=(640, 480), raster_layers=2,
                         atomic_threads=1 << 15, atomic_ops=32),
    },
    "full": {
        "gpu": dict(reps=50, copy_mib=1536, raster_size=(1920, 1080), raster_layers=32,
                    atomic_threads=1 << 21, atomic_ops=64),
        "software": dict(reps=10, copy_mib=64, raster_size=(1920, 1080), raster_layers=1,
                         atomic_threads=1 << 16, atomic_ops=64),
    },
}
SECTIONS = ("dram", "raster", "atomics")


class Bench(BenchRows):
    skip_errors = (Skip,)
    reason_limit = 400

    def __init__(self, ctx, mode: str = "default", progress=None, *, profiler_source: str | None = None):
        from ..gpu.capabilities import get_capabilities

        self._start(ctx, mode, MODE_CONFIG, progress, profiler_source=profiler_source, history=100_000)
        self.software = bool(get_capabilities(ctx).is_software)
        self.kind = "software" if self.software else "gpu"
        self.cfg = dict(MODE_CONFIG[mode][self.kind])

    # ------------------------------------------------------------------ timing
    def _time(self, key: str, fn) -> dict:
        """fn() once untimed, then cfg reps times in profiler sections: ms statistics."""
        fn()
        self.ctx.finish()
        for _ in range(int(self.cfg["reps"])):
            with self.prof.section(key):
                fn()
        ms = self.prof.samples(key, wait=True)
        if not ms or min(ms) <= 0:
            raise Skip(f"the profiler read no time for {key} ({ms})")
        return stats(ms)

    def _method(self) -> str:
        return (f"{int(self.cfg['reps'])} runs after an untimed one, each a GpuProfiler section "
                f"({self.prof.source}: {self.prof.reason}); value: the fastest run, value_median: the median")

    # ------------------------------------------------------------------ DRAM
    def dram(self) -> None:
        """The copy at cfg copy_mib and at a quarter of it (both far beyond the L2): drivers may
        place very large buffers where they are slower to reach; the peak is the best row."""
        mib0 = int(self.cfg["copy_mib"])
        for mib in dict.fromkeys((mib0, max(mib0 // 4, 8 if self.software else 256))):
            self._copy(mib)

    def _copy(self, mib: int) -> None:
        from ..errors import GPUMemoryError
        from ..gpu.microbench import CopyKernel

        with self._guard("dram", f"copy {mib} MiB"):
            while True:   # halve the buffers until two fit (at least 64 MiB on a GPU)
                name, size = f"copy {mib} MiB", mib << 20
                try:
                    kernel = CopyKernel(self.ctx, size)
                    break
                except GPUMemoryError:
                    if mib <= (8 if self.software else 64):
                        raise
                    mib //= 2
            count = kernel.count
            try:
                t = self._time(f"dram{mib}", kernel.run)
                ok = kernel.copied_ok()
            finally:
                kernel.release()
            if not ok:
                raise RuntimeError("the copy kernel did not copy (the destination's last bytes differ)")
            moved = 2 * size
            peak, key = peak_bandwidth(self._renderer())
            self._row("dram", name, buffer_bytes=size, bytes_per_run=moved, time_ms=t,
                      value=moved / (t["min"] * 1e-3) / 1e9, value_median=moved / (t["median"] * 1e-3) / 1e9,
                      unit="GB/s (10^9 bytes read + written per second)",
                      tabulated_GBps=None if peak is None else peak / 1e9, tabulated_model=key,
                      method=(f"limits_copy.comp: {count} uvec4 loads and stores, one a thread, from one {mib} MiB "
                              f"buffer to another; " + self._method()))

    # ------------------------------------------------------------------ raster units
    def raster(self) -> None:
        from ..gpu.microbench import RasterStrips, max_samples as gl_max_samples

        ctx = self.ctx
        W, H = (int(v) for v in self.cfg["raster_size"])
        layers = int(self.cfg["raster_layers"])
        strip_px = STRIP_SEGMENTS * SEG_PX
        per_row, rows = int(W // strip_px), int(H // WIDTH_PX)
        strips = per_row * rows * layers
        triangles = strips * 2 * STRIP_SEGMENTS
        pixels = int(strips * strip_px * WIDTH_PX)      # pixel-aligned: each pixel covered once a layer
        max_samples = gl_max_samples(ctx)
        for msaa in (4, 1):
            name = f"msaa {msaa} {W}x{H}"
            with self._guard("raster", name, msaa=msaa, size=[W, H]):
                if msaa > max_samples:
                    raise Skip(f"{msaa}x MSAA: this OpenGL gives at most {max_samples} samples")
                target = RasterStrips(ctx, (W, H), msaa, strips, per_row=per_row, rows=rows,
                                      segments=STRIP_SEGMENTS, seg_px=SEG_PX, width_px=WIDTH_PX)
                try:   # release() gives the context its framebuffer back
                    t = self._time(f"raster{msaa}", target.draw)
                    samples, samples_source = pixels * msaa, "pixels covered x samples (computed)"
                    try:
                        passed = target.samples_passed()
                        if passed > 0:
                            samples, samples_source = passed, "GL_SAMPLES_PASSED query"
                    except Exception as exc:   # no occlusion query: the computed count stands
                        samples_source += f" (the query failed: {type(exc).__name__})"
                finally:
                    target.release()
                best, med = t["min"] * 1e-3, t["median"] * 1e-3
                self._row("raster", name, msaa=msaa, size=[W, H], layers=layers, instances=strips,
                          triangles=triangles, triangle_pixels=SEG_PX * WIDTH_PX / 2, pixels=pixels,
                          samples=samples, samples_source=samples_source, time_ms=t,
                          triangles_per_s=triangles / best, triangles_per_s_median=triangles / med,
                          samples_per_s=samples / best, samples_per_s_median=samples / med,
                          pixels_per_s=pixels / best, value=triangles / best, value_median=triangles / med,
                          unit="triangles/s (samples_per_s: samples written per second; pixels_per_s: "
                               "fragment shader invocations per second)",
                          method=(f"{strips} instanced triangle strips of {STRIP_SEGMENTS} quads {SEG_PX:g} x "
                                  f"{WIDTH_PX:g} px ({triangles} triangles of {SEG_PX * WIDTH_PX / 2:g} px), "
                                  f"vertex pulling, {layers} layer(s) over {W}x{H}, RGBA16F "
                                  f"{'MSAA ' + str(msaa) + 'x' if msaa > 1 else 'one sample'}, trivial fragment "
                                  "shader, no depth test or blending; " + self._method()))

    # ------------------------------------------------------------------ atomics
    def atomics(self) -> None:
        from ..gpu.capabilities import has_atomic64
        from ..gpu.microbench import AtomicKernel

        threads, ops = int(self.cfg["atomic_threads"]), int(self.cfg["atomic_ops"])
        words = SAMPLE_GRID_WORDS
        have64 = has_atomic64(self.ctx)
        for bits in (32, 64):
            for pattern, label in ((0, "random"), (1, "sequential")):
                name = f"atomicMin {bits}-bit {label}"
                with self._guard("atomics", name, bits=bits, pattern=label):
                    if bits == 64 and not have64:
                        raise Skip("no 64-bit atomics (GL_NV_shader_atomic_int64): the compute rasteriser "
                                   "uses two 32-bit passes here")
                    kernel = AtomicKernel(self.ctx, words, bits, pattern, threads, ops)
                    try:
                        t = self._time(f"atomic{bits}{label}", kernel.run)
                    finally:
                        kernel.release()
                    n = threads * ops
                    self._row("atomics", name, bits=bits, pattern=label, words=words, buffer_bytes=words * bits // 8,
                              threads=threads, ops_per_thread=ops, ops=n, time_ms=t,
                              value=n / (t["min"] * 1e-3), value_median=n / (t["median"] * 1e-3),
                              unit="atomic operations/s",
                              method=(f"limits_atomic.comp: {threads} threads x {ops} atomicMin on "
                                      f"{bits}-bit words of a {words}-word buffer (1920x1080x4 samples), "
                                      + ("each at a random word (PCG hash)" if pattern == 0 else
                                         "each thread at consecutive words from a random one") + "; "
                                      + self._method()))

    # ------------------------------------------------------------------ all
    def _renderer(self) -> str:
        from ..gpu.context import renderer_name

        return renderer_name(self.ctx)

    def run_all(self, sections=None) -> None:
        check_sections("limits", sections, SECTIONS)
        for s in sections or SECTIONS:
            getattr(self, s)()

    def release(self) -> None:
        try:
            self.prof.release()
        except Exception:
            pass


# --------------------------------------------------------------------------- the measured peaks
def _best(rows, bench, **match):
    ok = [r for r in rows if r.get("bench") == bench and r.get("status") == "ok"
          and all(r.get(k) == v for k, v in match.items())]
    return max(ok, key=lambda r: r.get("value") or 0) if ok else None


def peaks_of(rows: list[dict], renderer: str = "") -> dict:
    """The limits in one place: DRAM copy GB/s; per MSAA count triangles/s, samples/s, pixels/s;
    atomicMin/s per width (random addresses; ``sequential``: consecutive words)."""
    tab, key = peak_bandwidth(renderer)
    d = _best(rows, "dram")
    out = {"dram_copy_GBps": d and d["value"], "dram_tabulated_GBps": None if tab is None else tab / 1e9,
           "dram_tabulated_model": key, "raster": {}, "atomic_min_per_s": {}, "atomic_min_sequential_per_s": {}}
    for msaa in (1, 4):
        r = _best(rows, "raster", msaa=msaa)
        if r:
            out["raster"][str(msaa)] = {k: r[k] for k in ("triangles_per_s", "samples_per_s", "pixels_per_s")}
    for bits in (32, 64):
        r = _best(rows, "atomics", bits=bits, pattern="random")
        if r:
            out["atomic_min_per_s"][str(bits)] = r["value"]
        r = _best(rows, "atomics", bits=bits, pattern="sequential")
        if r:
            out["atomic_min_sequential_per_s"][str(bits)] = r["value"]
    return out


def run(ctx, mode: str = "default", progress=None, sections=None) -> dict:
    """Every section (or ``sections``) of ``mode``: the JSON object."""
    bench = Bench(ctx, mode, progress)
    try:
        bench.run_all(sections)
        timing = {"source": bench.prof.source, "source_reason": bench.prof.reason,
                  "note": "value: from the fastest of the timed runs (the limit); value_median: the median",
                  "total_seconds": time.perf_counter() - bench.started}
    finally:
        bench.release()
    settings = {"kind": bench.kind, **{k: (list(v) if isinstance(v, tuple) else v) for k, v in bench.cfg.items()},
                "sample_grid_words": SAMPLE_GRID_WORDS,
                "strip": {"segments": STRIP_SEGMENTS, "segment_px": SEG_PX, "width_px": WIDTH_PX}}
    meta = envelope(ctx, target="limits", mode=mode, settings=settings, timing=timing)
    return {"meta": meta, "results": bench.rows, "peaks": peaks_of(bench.rows, meta["renderer"])}


# --------------------------------------------------------------------------- distance from the limits
def _m(v):
    return v.get("mean") if isinstance(v, dict) else v


def _pass_ms(row: dict, name: str):
    """A pass's mean ms: the gapless GPU figure where there is one, else the profiled one."""
    for key in ("gpu_passes_ms", "passes_ms"):
        v = _m((row.get(key) or {}).get(name))
        if v:
            return v, key
    return None, None


def _frac(a, b):
    return (a / b) if (a is not None and b) else None


def distance_rows(results: dict) -> list[dict]:
    """How far each stage is from its limit, from ``mane bench all``'s results ({"sim": ..,
    "render": .., "limits": ..}; any may be missing). One row per stage and configuration:
    ``achieved`` and ``limit`` in ``unit``, ``fraction`` = achieved / limit (the measured limit of
    limits.json), and for the solver ``tabulated_limit`` / ``tabulated_fraction`` too."""
    lim = results.get("limits") or {}
    peaks = lim.get("peaks") or (peaks_of(lim.get("results") or []) if lim else {})
    out = []
    # the solver: the integrate kernel's bytes per second against the copy kernel's
    bw = (results.get("sim") or {}).get("bandwidth") or {}
    if bw.get("achieved_GBps") is not None:
        copy = peaks.get("dram_copy_GBps")
        out.append({"stage": "solver", "path": "integrate kernel", "configuration": bw.get("configuration"),
                    "section": "dftl_core", "achieved": bw["achieved_GBps"], "unit": "GB/s", "limit": copy,
                    "limit_kind": "measured DRAM copy (limits.json)", "fraction": _frac(bw["achieved_GBps"], copy),
                    "tabulated_limit": bw.get("peak_GBps"), "tabulated_fraction": bw.get("fraction_of_peak"),
                    "tabulated_model": bw.get("peak_model"),
                    "how": f"{bw.get('bytes_per_step')} B read + written in {fmt(bw.get('time_ms'), '{:.4f}')} ms"})
    raster = peaks.get("raster") or {}
    atomic = peaks.get("atomic_min_per_s") or {}
    atomic_seq = peaks.get("atomic_min_sequential_per_s") or {}
    render_rows = [r for r in (results.get("render") or {}).get("results") or [] if r.get("status") == "ok"]
    for r in render_rows:
        rs = r.get("renderer_stats") or {}
        st = r.get("settings") or {}
        segs = r.get("rendered_segments") or 0
        hair_ms, hair_src = _pass_ms(r, "hair")
        if hair_ms and segs and rs.get("rasterizer", "hardware") == "hardware" \
                and (rs.get("geometry") or st.get("geometry")) != "lines":
            msaa = int(rs.get("msaa") or r.get("msaa") or 1)
            draws = 2 if (msaa > 1 and st.get("depth_prepass", True)) else 1
            tris = draws * 2 * segs
            rate = tris / (hair_ms * 1e-3)
            peak = (raster.get(str(msaa)) or {}).get("triangles_per_s")
            row = {"stage": "hair pass", "path": "hardware", "configuration": r.get("name"),
                   "section": r.get("bench"), "msaa": msaa, "achieved": rate, "unit": "triangles/s", "limit": peak,
                   "limit_kind": f"measured raster peak, {msaa}x MSAA (limits.json)" if peak else
                   f"no raster peak measured at {msaa}x MSAA",
                   "fraction": _frac(rate, peak), "time_ms": hair_ms, "time_source": hair_src, "triangles": tris,
                   "how": ("2 draws (depth pre-pass, shading)" if draws == 2 else "1 draw")
                          + f" x rendered_segments {segs} x 2 triangles / the hair pass's ms"}
            # samples: the compute rasteriser's count for the same configuration, where it ran
            twin = next((c for c in render_rows if c is not r and c.get("sample_visits")
                         and c.get("guides") == r.get("guides") and c.get("size") == r.get("size")
                         and c.get("rendered_segments") == segs
                         and (c.get("renderer_stats") or {}).get("raster_samples") == msaa), None)
            speak = (raster.get(str(msaa)) or {}).get("samples_per_s")
            if twin is not None:
                srate = draws * twin["sample_visits"] / (hair_ms * 1e-3)
                row.update(samples_estimated=draws * twin["sample_visits"], samples_per_s=srate,
                           samples_limit=speak, samples_fraction=_frac(srate, speak),
                           samples_how=f"sample_visits of '{twin.get('name')}' (the compute rasteriser's scan "
                                       f"conversion of the same strands, {msaa} samples a pixel) x {draws} draw(s)")
            out.append(row)
        raster_ms, raster_src = _pass_ms(r, "hair_raster")
        if raster_ms and r.get("raster_atomics"):
            bits = int(r.get("raster_atomic_bits") or 32)
            rate = r["raster_atomics"] / (raster_ms * 1e-3)
            peak = atomic.get(str(bits))
            out.append({"stage": "hair pass", "path": f"compute ({bits}-bit visibility)",
                        "configuration": r.get("name"), "section": r.get("bench"),
                        "msaa": (r.get("renderer_stats") or {}).get("raster_samples"), "achieved": rate,
                        "unit": "atomic operations/s", "limit": peak,
                        "limit_kind": f"measured atomicMin {bits}-bit, random addresses (limits.json)" if peak else
                        f"no {bits}-bit atomicMin rate measured",
                        "fraction": _frac(rate, peak), "time_ms": raster_ms, "time_source": raster_src,
                        "limit_sequential": atomic_seq.get(str(bits)),
                        "fraction_sequential": _frac(rate, atomic_seq.get(str(bits))),
                        "atomics": r["raster_atomics"], "sample_visits": r.get("sample_visits"),
                        "sample_writes": r.get("sample_writes"),
                        "sample_visits_per_s": (r.get("sample_visits") or 0) / (raster_ms * 1e-3),
                        "how": "raster_atomics (hair_raster.comp's RASTER_STATS counters, one extra frame) / the "
                               "hair_raster section's ms; a write is an atomic min (depth and id) and an atomic add "
                               "(coverage), the 32-bit path adds the id pass's atomicMax"})
    return out


# --------------------------------------------------------------------------- text output
def format_text(result: dict) -> str:
    meta, rows = result["meta"], result["results"]
    tm = meta["timing"]
    out = [title_line(meta), f"timing: {tm['source']} ({tm.get('source_reason')}); {tm['total_seconds']:.1f} s in all"]
    ok = lambda bench: [r for r in rows if r["bench"] == bench and r["status"] == "ok"]  # noqa: E731
    ms = lambda k: lambda r: (r.get("time_ms") or {}).get(k)  # noqa: E731
    out.append(table(ok("dram"), [("config", "name", "{}"), ("GB/s", "value", "{:.1f}"),
                                  ("GB/s median", "value_median", "{:.1f}"),
                                  ("tabulated GB/s", "tabulated_GBps", "{:.0f}"),
                                  ("ms min", ms("min"), "{:.4f}"), ("ms median", ms("median"), "{:.4f}")],
                     title="\nDRAM: streaming copy (bytes read + written)"))
    out.append(table(ok("raster"), [("config", "name", "{}"), ("triangles", "triangles", "{:d}"),
                                    ("G tri/s", lambda r: r["triangles_per_s"] / 1e9, "{:.3f}"),
                                    ("G samples/s", lambda r: r["samples_per_s"] / 1e9, "{:.3f}"),
                                    ("G pixels/s", lambda r: r["pixels_per_s"] / 1e9, "{:.3f}"),
                                    ("ms min", ms("min"), "{:.4f}")],
                     title="\nRaster units: 2-pixel triangles in strips, trivial fragment shader"))
    out.append(table(ok("atomics"), [("config", "name", "{}"), ("ops", "ops", "{:d}"),
                                     ("G ops/s", lambda r: r["value"] / 1e9, "{:.3f}"),
                                     ("G ops/s median", lambda r: r["value_median"] / 1e9, "{:.3f}"),
                                     ("ms min", ms("min"), "{:.4f}")],
                     title="\nAtomics into a 1920x1080x4-sample buffer"))
    bad = failures_table(rows)
    if bad:
        out += ["", bad]
    return "\n".join(out)


__all__ = ["run", "format_text", "peaks_of", "distance_rows", "MODE_CONFIG", "SECTIONS", "Bench"]
