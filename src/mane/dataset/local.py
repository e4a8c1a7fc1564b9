"""The embedded runner: no server. One GPU worker process per visible GPU (EGL device index
through glcontext's GLCONTEXT_DEVICE_INDEX), each with a pool of CPU processes that encode its
samples while it renders the next ones; shards handed out from a queue; the coordinator (this
process) records each finished shard in the manifest and draws the progress bar.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import queue
import shutil
import subprocess
import traceback
from concurrent.futures import ProcessPoolExecutor

from .job import Done, encode_timed, render_shard
from .report import RunReport
from .shards import plan_resume, shard_name, write_manifest
from .spec import DatasetSpec


def visible_gpus() -> list[int]:
    """The NVIDIA GPUs' indices (CUDA_VISIBLE_DEVICES when set and numeric, else nvidia-smi -L);
    [] when none. The EGL device index of a worker is its GPU's index."""
    cuda = os.environ.get("CUDA_VISIBLE_DEVICES")
    if cuda is not None:
        ids = [d.strip() for d in cuda.split(",") if d.strip() and d.strip() != "-1"]
        if all(d.isdigit() for d in ids):
            return [int(d) for d in ids]
    if shutil.which("nvidia-smi") is None:
        return []
    try:
        out = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=20).stdout
    except (OSError, subprocess.SubprocessError):
        return []
    return [i for i, line in enumerate(ln for ln in out.splitlines() if ln.startswith("GPU "))]


def default_encoders(workers: int) -> int:
    return max(1, (os.cpu_count() or 2) // max(workers, 1) - 1)


def _gpu_main(wid: int, device: tuple | None, spec: DatasetSpec, out_dir: str, encoders: int, tasks, results) -> None:
    from ..errors import GPUError

    if device is not None:
        os.environ["GLCONTEXT_DEVICE_INDEX"] = str(device[0])
    try:
        from .worker import SampleRenderer

        try:
            sr = SampleRenderer(spec)
        except GPUError:
            if device is None or device[0] == device[1]:
                raise
            # a driver whose EGL lists only the CUDA_VISIBLE_DEVICES: their position
            os.environ["GLCONTEXT_DEVICE_INDEX"] = str(device[1])
            sr = SampleRenderer(spec)
        results.put(("ready", wid, sr.renderer_string))
    except Exception as exc:
        results.put(("fatal", wid, f"{type(exc).__name__}: {exc}"))
        return
    pool = ProcessPoolExecutor(encoders, mp_context=mp.get_context("spawn")) if encoders > 0 else None

    def submit(job):
        if pool is None:
            return Done(encode_timed(job))
        return pool.submit(encode_timed, job)

    try:
        while True:
            k = tasks.get()
            if k is None:
                break
            results.put(("start", wid, k))
            try:
                info = render_shard(sr, k, out_dir, submit, in_flight=max(2, 2 * encoders),
                                    on_sample=lambda: results.put(("sample", wid, 1)),
                                    prefetch=pool.submit if pool is not None else None)
            except Exception as exc:
                results.put(("error", wid, k, f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=3)}"))
                continue
            results.put(("done", wid, k, info))
    finally:
        if pool is not None:
            pool.shutdown()
        sr.release()


def run_local(spec: DatasetSpec, out_dir, *, workers: int | None = None, encoders: int | None = None,
              progress: bool = True) -> RunReport:
    manifest, todo, redo = plan_resume(spec, out_dir)
    write_manifest(out_dir, manifest)
    gpus = visible_gpus()
    n = int(workers) if workers else max(1, len(gpus))
    n = max(1, min(n, len(todo) or 1))
    enc = default_encoders(n) if encoders is None else int(encoders)
    report = RunReport(spec, out_dir, "local", n, todo, redo)
    if not todo:
        return report.finish(manifest)
    ctx = mp.get_context("spawn")
    tasks, results = ctx.Queue(), ctx.Queue()
    for k in todo:
        tasks.put(k)
    for _ in range(n):
        tasks.put(None)
    # EGL device per worker: (the GPU's index, its position among the visible ones)
    devices = [(gpus[w % len(gpus)], w % len(gpus)) if len(gpus) > 1 else None for w in range(n)]
    procs = [ctx.Process(target=_gpu_main, args=(w, devices[w], spec, str(out_dir), enc, tasks, results), daemon=False)
             for w in range(n)]
    for p in procs:
        p.start()
    current: dict = {}
    bar = report.progress_bar(progress)
    try:
        while True:
            try:
                msg = results.get(timeout=0.5)
            except queue.Empty:
                msg = None
            for w, p in enumerate(procs):   # a worker that died mid-shard: its shard failed
                if w in current and not p.is_alive() and p.exitcode not in (0, None):
                    report.failed[current.pop(w)] = f"worker {w} died (exit code {p.exitcode})"
            if msg is None:
                if all(not p.is_alive() for p in procs) and results.empty():
                    break
                continue
            kind, w = msg[0], msg[1]
            if kind == "ready":
                report.add_renderer(msg[2])
            elif kind == "fatal":
                report.fatal.append(f"worker {w}: {msg[2]}")
            elif kind == "start":
                current[w] = msg[2]
            elif kind == "sample":
                bar.update(1)
            elif kind == "error":
                current.pop(w, None)
                report.failed[msg[2]] = msg[3].splitlines()[0]
            elif kind == "done":
                info = msg[3]
                current.pop(w, None)
                report.shard_done(manifest, info)
                write_manifest(out_dir, manifest)
    finally:
        bar.close()
        for p in procs:
            p.join(timeout=5)
            if p.is_alive():
                p.terminate()
    # a shard a dead worker was on, or one no worker got to because every worker died
    for k in todo:
        if shard_name(k) not in manifest["shards"] and k not in report.failed:
            report.failed[k] = "not rendered (every worker stopped)"
    return report.finish(manifest)
