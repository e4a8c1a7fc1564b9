"""What a run did: shards rendered, kept from before, redone (and why), failed; samples per
second; where the time went. Also the progress bar (tqdm: samples, samples/s, ETA)."""
from __future__ import annotations

import time

from .shards import shard_name
from .spec import DatasetSpec


class RunReport:
    def __init__(self, spec: DatasetSpec, out_dir, runner: str, workers: int, todo: list, redo: dict):
        self.spec, self.out_dir, self.runner, self.workers = spec, str(out_dir), runner, workers
        self.todo = list(todo)
        self.redo = dict(redo)
        self.done: list[int] = []
        self.infos: list[dict] = []   # render_shard's entries of the shards done
        self.failed: dict = {}
        self.fatal: list[str] = []
        self.renderers: list[str] = []
        self.timings: dict = {}
        self.samples = 0
        self.start = time.perf_counter()
        self.wall = 0.0

    def progress_bar(self, enabled: bool):
        from tqdm import tqdm

        total = sum(len(self.spec.shard_range(k)) for k in self.todo)
        return tqdm(total=total, unit="sample", disable=not enabled, desc=f"mane dataset ({self.runner})",
                    smoothing=0.1, dynamic_ncols=True)

    def add_renderer(self, name: str) -> None:
        if name not in self.renderers:
            self.renderers.append(name)

    def shard_done(self, manifest: dict, info: dict) -> None:
        k = int(info["shard"])
        manifest["shards"][shard_name(k)] = {"samples": info["samples"], "sha256": info["sha256"],
                                             "bytes": info["bytes"], "first": self.spec.shard_range(k).start}
        for r in self.renderers:
            if r not in manifest["renderers"]:
                manifest["renderers"].append(r)
        self.done.append(k)
        self.infos.append(info)
        self.failed.pop(k, None)
        self.samples += info["samples"]
        for name, v in info.get("timings", {}).items():
            self.timings[name] = self.timings.get(name, 0.0) + v

    def finish(self, manifest: dict) -> "RunReport":
        self.wall = time.perf_counter() - self.start
        self.complete = len(manifest["shards"]) == self.spec.num_shards
        return self

    @property
    def ok(self) -> bool:
        return self.complete and not self.failed and not self.fatal

    def as_dict(self) -> dict:
        return {"runner": self.runner, "workers": self.workers, "out": self.out_dir,
                "shards_total": self.spec.num_shards, "rendered": sorted(self.done),
                "kept": self.spec.num_shards - len(self.todo),
                "redone": {str(k): v for k, v in sorted(self.redo.items())},
                "failed": {str(k): v for k, v in sorted(self.failed.items())}, "fatal": self.fatal,
                "samples": self.samples, "wall_s": round(self.wall, 3),
                "samples_per_s": round(self.samples / self.wall, 3) if self.wall > 0 else None,
                "timings_s": {k: round(v, 4) for k, v in self.timings.items()}, "renderers": self.renderers,
                "complete": self.complete}

    def steady_rate(self) -> float | None:
        """Samples per second once every worker is warm: the shards after each worker's first,
        from the first of them starting to the last ending (None: too few shards)."""
        firsts: dict = {}
        for info in sorted(self.infos, key=lambda i: i["started"]):
            firsts.setdefault(info["pid"], info["shard"])
        rest = [i for i in self.infos if firsts[i["pid"]] != i["shard"]]
        if not rest:
            return None
        span = max(i["ended"] for i in rest) - min(i["started"] for i in rest)
        return sum(i["samples"] for i in rest) / span if span > 0 else None

    def lines(self) -> list[str]:
        d = self.as_dict()
        out = [f"{d['runner']}: {len(d['rendered'])} shard(s) rendered, {d['kept']} kept from before, "
               f"{d['samples']} samples in {d['wall_s']:.1f} s ({d['samples_per_s'] or 0:.2f} samples/s) "
               f"with {self.workers} GPU worker(s) on {', '.join(self.renderers) or '-'}"]
        for k, why in sorted(self.redo.items()):
            out.append(f"redone: {shard_name(k)}: {why}")
        for k, why in sorted(self.failed.items()):
            out.append(f"FAILED: {shard_name(k)}: {why}")
        for f in self.fatal:
            out.append(f"FATAL: {f}")
        if self.failed or self.fatal:
            out.append("the finished shards are kept; rerun the same command to redo the others")
        elif self.complete:
            out.append(f"complete: {self.spec.num_shards} shard(s), {self.spec.samples} samples in {self.out_dir}")
        return out
