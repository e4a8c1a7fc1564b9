"""One shard's work, the same for the local runner and Ray: render its samples in order on
this process's GPU, hand each to an encoder (``submit(raw) -> future``), stream the encoded
samples into the shard's temporary file in order, rename it when complete.

A fault hook for tests: with ``MANE_DATASET_EXIT_AFTER=N`` in its environment a worker process
exits abruptly (os._exit, like a killed process) once it has rendered N samples.
"""
from __future__ import annotations

import os
import time
from collections import deque

from .encode import encode_sample
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


def encode_timed(raw: dict, outputs) -> tuple[dict, float]:
    t = time.perf_counter()
    files = encode_sample(raw, outputs)
    return files, time.perf_counter() - t


def render_shard(sr, k: int, out_dir, submit, *, in_flight: int = 8, on_sample=None) -> dict:
    """Render shard ``k`` with SampleRenderer ``sr``; returns its manifest entry and timings."""
    global _rendered
    spec = sr.spec
    exit_after = int(os.environ.get(EXIT_AFTER_ENV, "0") or 0)
    t0 = time.perf_counter()
    before = dict(sr.timings)
    shard = ShardFile(out_dir, k)
    pending: deque = deque()
    encode_s = write_s = submit_s = wait_s = 0.0

    def drain(block: bool) -> None:
        nonlocal encode_s, write_s, wait_s
        while pending and (block or len(pending) > in_flight or pending[0].done()):
            t = time.perf_counter()
            files, enc = pending.popleft().result()
            wait_s += time.perf_counter() - t
            t = time.perf_counter()
            shard.write(files)
            write_s += time.perf_counter() - t
            encode_s += enc
            if on_sample is not None:
                on_sample()

    try:
        for i in spec.shard_range(k):
            if exit_after and _rendered >= exit_after:
                os._exit(17)   # the fault hook: as abrupt as a kill
            raw = sr.render(sample_params(spec, i))
            t = time.perf_counter()
            pending.append(submit(raw))
            submit_s += time.perf_counter() - t
            _rendered += 1
            drain(False)
        drain(True)
        sha, size = shard.close()
    except BaseException:
        shard.abort()
        raise
    timings = {name: sr.timings[name] - before.get(name, 0.0) for name in sr.timings}
    return {"shard": k, "samples": shard.samples, "sha256": sha, "bytes": size,
            "timings": {**timings, "submit": submit_s, "wait_encoders": wait_s, "encode": encode_s, "write": write_s,
                        "wall": time.perf_counter() - t0}}
