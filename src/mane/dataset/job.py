"""One shard's work, the same for the local runner and Ray: render its samples in order on
this process's GPU, one frame ahead (sample N + 1 is issued before sample N is read back, so
the GPU renders while the CPU reads and packs), make its cheap files here and hand its PNGs to
an encoder (``submit(job) -> future``), stream the encoded samples into the shard's temporary
file in order (a writer thread, overlapping the next renders), rename it when complete.

A fault hook for tests: with ``MANE_DATASET_EXIT_AFTER=N`` in its environment a worker process
exits abruptly (os._exit, like a killed process) once it has rendered N samples.
"""
from __future__ import annotations

import os
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor

from .encode import encode_arrays, encode_pngs, png_job
from .sampling import sample_params
from .shards import ShardFile

EXIT_AFTER_ENV = "MANE_DATASET_EXIT_AFTER"
_rendered = 0


class Done:
    """A finished future (encoding inline)."""

    def __init__(self, value):
        self.value = value

    def done(self) -> bool:
        return True

    def result(self):
        return self.value


def encode_timed(job: dict) -> tuple[dict, float]:
    """An encoder's task: a sample's PNGs (encode.png_job) and the seconds they took."""
    t = time.perf_counter()
    files = encode_pngs(job)
    return files, time.perf_counter() - t


def render_shard(sr, k: int, out_dir, submit, *, in_flight: int = 8, on_sample=None, prefetch=None) -> dict:
    """Render shard ``k`` with SampleRenderer ``sr``; returns its manifest entry and timings.
    ``prefetch(fn, *args) -> future``: CPU workers that grow the next grooms meanwhile."""
    spec = sr.spec
    exit_after = int(os.environ.get(EXIT_AFTER_ENV, "0") or 0)
    t0, started = time.perf_counter(), time.time()
    before = dict(sr.timings)
    shard = ShardFile(out_dir, k)
    pending: deque = deque()     # (files made here, the encoder's future), in sample order
    writes: deque = deque()      # the writer thread's futures, in order
    writer = ThreadPoolExecutor(1, thread_name_prefix="mane-shard-writer")
    encode_s = write_s = submit_s = wait_s = arrays_s = 0.0

    def write(files: dict) -> float:   # in the writer thread: file writes release the GIL
        t = time.perf_counter()
        shard.write(files)
        return time.perf_counter() - t

    def drain(block: bool) -> None:
        nonlocal encode_s, write_s, wait_s
        while pending and (block or len(pending) > in_flight or pending[0][1].done()):
            t = time.perf_counter()
            files, future = pending.popleft()
            pngs, enc = future.result()
            files.update(pngs)
            wait_s += time.perf_counter() - t
            encode_s += enc
            writes.append(writer.submit(write, files))
            while writes and (block or len(writes) > in_flight or writes[0].done()):
                write_s += writes.popleft().result()
            if on_sample is not None:
                on_sample()

    def finish(ticket) -> None:   # sample N's read-back and files, while the GPU renders N + 1
        global _rendered
        nonlocal arrays_s, submit_s
        if exit_after and _rendered >= exit_after:
            os._exit(17)   # the fault hook: as abrupt as a kill
        raw = sr.finish(ticket)
        t = time.perf_counter()
        files = encode_arrays(raw, spec.outputs)
        arrays_s += time.perf_counter() - t
        t = time.perf_counter()
        pending.append((files, submit(png_job(raw, spec.outputs))))
        submit_s += time.perf_counter() - t
        _rendered += 1
        drain(False)

    try:
        params = [sample_params(spec, i) for i in spec.shard_range(k)]
        started_ticket = None
        for j, p in enumerate(params):
            if prefetch is not None:
                sr.prefetch(params[j:j + 2 * spec.views_per_groom + 2], prefetch)
            ticket = sr.start(p)
            if started_ticket is not None:
                finish(started_ticket)
            started_ticket = ticket
        if started_ticket is not None:
            finish(started_ticket)
        drain(True)
        while writes:
            write_s += writes.popleft().result()
        writer.shutdown()
        sha, size = shard.close()
    except BaseException:
        sr.cancel()
        writer.shutdown(wait=True, cancel_futures=True)
        shard.abort()
        raise
    timings = {name: sr.timings[name] - before.get(name, 0.0) for name in sr.timings}
    return {"shard": k, "samples": shard.samples, "sha256": sha, "bytes": size, "pid": os.getpid(),
            "started": started, "ended": time.time(),
            "timings": {**timings, "encode_arrays": arrays_s, "submit": submit_s, "wait_encoders": wait_s,
                        "encode_png": encode_s, "write_overlapped": write_s,
                        "wall": time.perf_counter() - t0}}
