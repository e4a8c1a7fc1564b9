"""``mane bench dataset``: samples per second of `mane dataset run`'s pipeline on this machine's
GPU (one GPU worker, cores - 1 encoder processes), and where the time goes.

Measurements on the same spec (default: 512x512, every map, 50k rendered strands = 3125
guides x 16, 16 points, deep opacity shadows, 4 samples a pixel; --quick: 128x128 and 2k
strands for CPUs). The shards go to a temporary folder under $TMPDIR (``TMPDIR=/dev/shm``
takes the disk out of it; the JSON's ``tmp_dir`` says where):

- ``stages``: samples rendered without encoding, per sample (SampleRenderer.timings):
  ``prepare`` (the sample's scene on the CPU), ``issue`` (the CPU issuing the frame and its
  read-back copies), ``gpu_wait`` (waiting for the frame's fence), ``readback`` (mapping the
  copies into arrays), ``camera_strands`` (camera.json's values, the strands in camera space);
  rendered one at a time (``render_alone_samples_per_s``) and one frame ahead as a run does
  (``render_ahead_samples_per_s``: the GPU renders N + 1 while the CPU reads N); the
  .npy/.json/.npz files (``encode_arrays``) and the PNGs of one sample on one core
  (``encode_png_one_core``), its bytes per file;
- ``pipeline``: a whole shard through render_shard with the encoder pool, as a run does:
  samples per second (the figure); the GPU process's ms a sample (prepare, issue, gpu_wait,
  readback, camera_strands, encode_arrays, submit: handing the PNG job to the pool,
  wait_encoders: blocked on the oldest sample's PNGs); its busy CPU (all but the waits); the
  encoders' CPU a sample (encode_png, summed over encoders) and the writer thread's
  (write_overlapped);
- ``ceiling``: the same shard with rendering replaced by replaying already-rendered raw
  samples: what encoding and writing alone sustain with this many cores (if it is below the
  target, no GPU makes the pipeline reach it);
- the bounds: 1 / (the GPU process's busy CPU a sample) and encoders / encode time;
- ``dataset_run`` rows: the local runner itself with 1, 2, 4 (full: 8) GPU worker processes on
  the GPU (each its own context; their CPU work runs in parallel, their frames interleave):
  samples per second once warm, and over the whole run.
"""
from __future__ import annotations

import os
import tempfile
import time

from .common import envelope, fmt, title_line

MODES = {
    "quick": {"size": (128, 128), "guides": 250, "strands_per_guide": 8, "samples": 8, "stage_samples": 4,
              "workers": (1,), "run_samples": 8},
    "default": {"size": (512, 512), "guides": 3125, "strands_per_guide": 16, "samples": 300, "stage_samples": 30,
                "workers": (1, 2, 4), "run_samples": 1200},
    "full": {"size": (512, 512), "guides": 3125, "strands_per_guide": 16, "samples": 2000, "stage_samples": 100,
             "workers": (1, 2, 4, 8), "run_samples": 4000},
}
OUTPUTS = ["rgb", "mask", "depth", "depth16", "orientation", "ids", "camera", "strands"]


def bench_spec(cfg: dict, base_dir: str, samples: int | None = None, per_shard: int | None = None):
    from ..dataset.spec import parse_spec

    samples = int(samples or cfg["samples"])
    return parse_spec({
        "name": "bench", "seed": 0, "samples": samples, "samples_per_shard": int(per_shard or samples),
        "views_per_groom": 100000, "size": list(cfg["size"]), "outputs": OUTPUTS,
        "grooms": [{"style": "long_wavy", "strands": cfg["guides"], "points": 16, "seeds": [0, 0]}],
        "colors": {"presets": ["black", "brown", "blond", "red"]},
        "views": {"azimuth": [-180, 180], "elevation": [-5, 30], "distance": [0.8, 1.1]},
        "lights": {"count": [1, 3]},
        "render": {"strands_per_guide": cfg["strands_per_guide"], "msaa": 4, "shadows": "deep_opacity"},
    }, base_dir)


class Replay:
    """A SampleRenderer for render_shard that hands back already-rendered raw samples (in turn,
    keyed as the shard's): the encoding and writing side of the pipeline alone."""

    def __init__(self, spec, raws: list):
        self.spec, self.raws = spec, raws
        self.timings: dict = {}

    def prefetch(self, upcoming, submit, ahead: int = 2) -> None:
        pass

    def start(self, p):
        return p

    def finish(self, p) -> dict:
        return {**self.raws[p.index % len(self.raws)], "key": p.key, "index": p.index}

    def cancel(self) -> None:
        pass


BUSY = ("prepare", "issue", "readback", "camera_strands", "encode_arrays", "submit")   # the GPU process's CPU


def shard_row(info: dict, wall: float) -> dict:
    """A render_shard result as samples/s and ms a sample per stage."""
    n = info["samples"]
    per = {k: 1000.0 * v / n for k, v in info["timings"].items() if k != "wall"}
    busy = sum(per.get(k, 0.0) for k in BUSY)
    return {"samples": n, "samples_per_s": n / wall, "wall_s": wall, "ms_per_sample": per,
            "gpu_process_busy_ms": busy, "bound_gpu_process_samples_per_s": 1000.0 / max(busy, 1e-9)}


def run(ctx, mode: str = "default", progress=None) -> dict:
    import pickle
    from concurrent.futures import ProcessPoolExecutor
    import multiprocessing as mp

    from ..dataset.encode import encode_arrays, png_job
    from ..dataset.job import encode_timed, render_shard
    from ..dataset.sampling import sample_params
    from ..dataset.worker import SampleRenderer

    cfg = dict(MODES[mode])
    log = progress or (lambda msg: None)
    started = time.perf_counter()
    encoders = max(1, (os.cpu_count() or 2) - 1)
    with tempfile.TemporaryDirectory(prefix="mane_bench_dataset_") as tmp:
        spec = bench_spec(cfg, tmp)
        log(f"{cfg['size'][0]}x{cfg['size'][1]}, {cfg['guides'] * cfg['strands_per_guide']} strands: growing the groom "
            "and compiling")
        sr = SampleRenderer(spec, ctx=ctx, cache=2)
        try:
            # warm: the groom, the programs, and each colour's tables (a first sample of each)
            firsts = {}
            for i in range(min(spec.samples, 64)):
                firsts.setdefault(sample_params(spec, i).color_preset, i)
            raws = [sr.render(sample_params(spec, i)) for i in sorted(set(firsts.values()) | {0, 1})]
            n = int(cfg["stage_samples"])
            log(f"stages: {n} samples rendered one at a time, {n} one frame ahead")
            for k in sr.timings:
                sr.timings[k] = 0.0
            t = time.perf_counter()
            for i in range(n):
                raws[i % len(raws)] = sr.render(sample_params(spec, 2 + i))
            alone = time.perf_counter() - t
            stage = {k: 1000.0 * v / n for k, v in sr.timings.items()}
            for k in sr.timings:
                sr.timings[k] = 0.0
            t = time.perf_counter()
            ticket = None
            for i in range(n):
                nxt = sr.start(sample_params(spec, 2 + n + i))
                if ticket is not None:
                    sr.finish(ticket)
                ticket = nxt
            sr.finish(ticket)
            ahead = time.perf_counter() - t
            stage_ahead = {k: 1000.0 * v / n for k, v in sr.timings.items()}
            arr_ms, enc_ms, files_bytes = [], [], {}
            for raw in raws[-2:]:
                t = time.perf_counter()
                files = encode_arrays(raw, spec.outputs)
                arr_ms.append(1000.0 * (time.perf_counter() - t))
                pngs, s = encode_timed(png_job(raw, spec.outputs))
                enc_ms.append(1000.0 * s)
                files_bytes = {k: len(v) for k, v in sorted({**files, **pngs}.items()) if k != "__key__"}
            t = time.perf_counter()
            pickled = len(pickle.dumps(png_job(raws[0], spec.outputs), protocol=pickle.HIGHEST_PROTOCOL))
            pickle_ms = 1000.0 * (time.perf_counter() - t)
            stage.update({"encode_arrays": sum(arr_ms) / len(arr_ms), "encode_png_one_core": sum(enc_ms) / len(enc_ms),
                          "pickle": pickle_ms})
            log(f"pipeline: {spec.samples} samples, {encoders} encoder processes; then the same replayed "
                "(rendering replaced by rendered samples)")
            with ProcessPoolExecutor(encoders, mp_context=mp.get_context("spawn")) as pool:
                list(pool.map(abs, range(encoders)))   # start the encoders before timing

                def submit(job):
                    return pool.submit(encode_timed, job)

                t = time.perf_counter()
                info = render_shard(sr, 0, tmp, submit, in_flight=2 * encoders)
                pipe = shard_row(info, time.perf_counter() - t)
                os.makedirs(os.path.join(tmp, "replay"))
                t = time.perf_counter()
                info = render_shard(Replay(spec, raws), 0, os.path.join(tmp, "replay"), submit, in_flight=2 * encoders)
                ceiling = shard_row(info, time.perf_counter() - t)
        finally:
            sr.release()
    runs = []
    for w in cfg.get("workers", ()):
        runs.append(run_workers(cfg, w, log))
    per = pipe["ms_per_sample"]
    nbytes = sum(files_bytes.values())
    row = {
        "bench": "dataset", "name": f"{cfg['size'][0]}x{cfg['size'][1]}", "status": "ok",
        "samples": pipe["samples"], "samples_per_s": pipe["samples_per_s"], "wall_s": pipe["wall_s"],
        "size": list(cfg["size"]), "rendered_strands": cfg["guides"] * cfg["strands_per_guide"],
        "outputs": OUTPUTS, "encoders": encoders, "tmp_dir": tempfile.gettempdir(),
        "bytes_per_sample": nbytes, "bytes_per_file": files_bytes, "png_job_pickle_bytes": pickled,
        "stage_ms_per_sample": stage, "render_alone_samples_per_s": n / alone,
        "stage_ahead_ms_per_sample": stage_ahead, "render_ahead_samples_per_s": n / ahead,
        "pipeline_ms_per_sample": per, "gpu_process_busy_ms": pipe["gpu_process_busy_ms"],
        "bound_gpu_process_samples_per_s": pipe["bound_gpu_process_samples_per_s"],
        "encoder_ms_per_sample": per.get("encode_png", 0.0),
        "writer_ms_per_sample": per.get("write_overlapped", 0.0),
        "bound_encoders_samples_per_s": 1000.0 * encoders / max(per.get("encode_png", 0.0), 1e-9),
        "ceiling_samples_per_s": ceiling["samples_per_s"], "ceiling_ms_per_sample": ceiling["ms_per_sample"],
    }
    meta = envelope(ctx, target="dataset", mode=mode, settings={**cfg, "size": list(cfg["size"]), "encoders": encoders},
                    timing={"source": "cpu wall clock (GPU waits: a fence after each frame's read-back copies)",
                            "total_seconds": time.perf_counter() - started})
    return {"meta": meta, "results": [row] + runs}


def run_workers(cfg: dict, workers: int, log) -> dict:
    """`mane dataset run`'s local runner with ``workers`` GPU worker processes on this machine's
    (first) GPU, each with cores / workers - 1 encoders: samples per second once warm (the
    shards after each worker's first) and over the whole run (start-up included)."""
    from ..dataset.local import default_encoders, run_local

    n = int(cfg["run_samples"])
    per_shard = max(1, n // (4 * workers))
    with tempfile.TemporaryDirectory(prefix="mane_bench_dataset_run_") as tmp:
        spec = bench_spec(cfg, tmp, samples=n, per_shard=per_shard)
        log(f"mane dataset run: {n} samples, {workers} GPU worker process(es), {default_encoders(workers)} "
            "encoders each")
        report = run_local(spec, tmp + "/out", workers=workers, progress=False)
    d = report.as_dict()
    status = "ok" if report.ok else "failed"
    return {"bench": "dataset_run", "name": f"{workers} worker(s)", "status": status, "workers": workers,
            "encoders_per_worker": default_encoders(workers), "samples": d["samples"], "samples_per_shard": per_shard,
            "steady_samples_per_s": report.steady_rate(), "run_samples_per_s": d["samples_per_s"],
            "wall_s": d["wall_s"], "timings_s": d["timings_s"], "problems": {**d["failed"], "fatal": d["fatal"]}}


def format_text(result: dict) -> str:
    meta, r = result["meta"], result["results"][0]
    runs = [x for x in result["results"][1:] if x.get("bench") == "dataset_run"]
    st, sa, pp, cl = (r["stage_ms_per_sample"], r["stage_ahead_ms_per_sample"], r["pipeline_ms_per_sample"],
                      r["ceiling_ms_per_sample"])
    ms = lambda d, k: fmt(d.get(k), "{:.2f}")  # noqa: E731
    gpu = lambda d: (f"prepare {ms(d, 'prepare')}, issue {ms(d, 'issue')}, GPU wait {ms(d, 'gpu_wait')}, "  # noqa: E731
                     f"read-back {ms(d, 'readback')}, camera+strands {ms(d, 'camera_strands')}")
    return "\n".join([
        title_line(meta),
        f"{r['samples']} samples of {r['name']}, {r['rendered_strands']} strands, outputs {', '.join(r['outputs'])}: "
        f"{r['samples_per_s']:.2f} samples/s with 1 GPU worker and {r['encoders']} encoders "
        f"({r['bytes_per_sample'] / 1e6:.2f} MB a sample, written under {r['tmp_dir']})",
        f"  GPU process, ms a sample: {gpu(pp)}, .npy/.json/.npz {ms(pp, 'encode_arrays')}, submit "
        f"{ms(pp, 'submit')}, waiting on encoders {ms(pp, 'wait_encoders')}; busy {r['gpu_process_busy_ms']:.2f} "
        f"-> bound {r['bound_gpu_process_samples_per_s']:.1f} samples/s",
        f"  encoders: {r['encoder_ms_per_sample']:.2f} ms CPU a sample -> bound {r['bound_encoders_samples_per_s']:.1f} "
        f"samples/s on {r['encoders']}; writer thread {r['writer_ms_per_sample']:.2f} ms a sample",
        f"  pipeline ceiling (rendering replaced by replaying rendered samples): {r['ceiling_samples_per_s']:.1f} "
        f"samples/s (.npy/.json/.npz {ms(cl, 'encode_arrays')}, submit {ms(cl, 'submit')}, waiting on encoders "
        f"{ms(cl, 'wait_encoders')}, encoders {ms(cl, 'encode_png')}, writer {ms(cl, 'write_overlapped')} ms a sample)",
        f"  rendering alone: {r['render_alone_samples_per_s']:.1f} samples/s one at a time ({gpu(st)}), "
        f"{r['render_ahead_samples_per_s']:.1f} one frame ahead ({gpu(sa)})",
        f"  one sample: .npy/.json/.npz {ms(st, 'encode_arrays')}, pickle of the PNG job {ms(st, 'pickle')}, "
        f"PNGs {ms(st, 'encode_png_one_core')} on one core; bytes: "
        + ", ".join(f"{k} {v / 1e3:.0f} kB" for k, v in r["bytes_per_file"].items()),
    ] + [f"  mane dataset run, {x['workers']} GPU worker(s) x {x['encoders_per_worker']} encoders: "
         f"{fmt(x['steady_samples_per_s'], '{:.1f}')} samples/s once warm, {fmt(x['run_samples_per_s'], '{:.1f}')} "
         f"over the run ({x['samples']} samples, {x['wall_s']:.1f} s) [{x['status']}]" for x in runs])
