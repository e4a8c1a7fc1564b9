"""The same work on Ray: one actor per GPU (``num_gpus=1``; on machines without GPUs
``num_cpus=1`` actors, ``--workers N``), each rendering whole shards handed out from a work
queue by this driver, with its samples encoded by Ray CPU tasks. Shards are written by the
actors straight into DIR (on a cluster of several machines DIR must be a shared filesystem),
temporary name then rename; the driver keeps the manifest.

    ray start --head                                   # once, on the head machine
    mane dataset run SPEC --out DIR --ray auto         # join it
    mane dataset run SPEC --out DIR --ray              # or start a local cluster for this run
"""
from __future__ import annotations

import os

from ..errors import UsageError
from .job import Done, encode_timed, render_shard
from .report import RunReport
from .shards import plan_resume, write_manifest
from .spec import DatasetSpec


class _Ref:
    """A Ray object ref with the two methods render_shard uses."""

    def __init__(self, ref):
        self.ref = ref

    def done(self) -> bool:
        import ray

        ready, _ = ray.wait([self.ref], timeout=0)
        return bool(ready)

    def result(self):
        import ray

        return ray.get(self.ref)


def _call(fn, *args):
    """A Ray CPU task running ``fn(*args)`` (a groom grown ahead: worker.make_groom)."""
    return fn(*args)


class ShardActor:
    """A GPU worker: its own context on its GPU (the EGL device of the GPU Ray gave it)."""

    def __init__(self, spec: DatasetSpec, out_dir: str, inline_encode: bool):
        import ray

        from ..errors import GPUError
        from .worker import SampleRenderer

        ids = ray.get_gpu_ids()
        self.spec, self.out_dir = spec, out_dir
        if ids:   # Ray's physical GPU id as the EGL device index
            os.environ["GLCONTEXT_DEVICE_INDEX"] = str(int(ids[0]))
        try:
            self.sr = SampleRenderer(spec)
        except GPUError:
            if not ids or int(ids[0]) == 0:
                raise
            # a driver whose EGL lists only the devices in CUDA_VISIBLE_DEVICES: the first
            os.environ["GLCONTEXT_DEVICE_INDEX"] = "0"
            self.sr = SampleRenderer(spec)
        self.encode = None if inline_encode else ray.remote(num_cpus=1)(encode_timed)
        self.tasks = ray.remote(num_cpus=1)(_call)

    def renderer(self) -> str:
        return self.sr.renderer_string

    def run_shard(self, k: int) -> dict:
        def submit(job):
            if self.encode is None:
                return Done(encode_timed(job))
            return _Ref(self.encode.remote(job))

        def prefetch(fn, *args):
            return _Ref(self.tasks.remote(fn, *args))

        return render_shard(self.sr, k, self.out_dir, submit, in_flight=8,
                            prefetch=None if self.encode is None else prefetch)


def run_ray(spec: DatasetSpec, out_dir, *, address: str | None = None, workers: int | None = None,
            progress: bool = True) -> RunReport:
    try:
        import ray
    except ImportError:
        raise UsageError("--ray needs Ray: pip install 'mane[dataset]' (ray==2.60.0)") from None
    manifest, todo, redo = plan_resume(spec, out_dir)
    write_manifest(out_dir, manifest)
    started = False
    if not ray.is_initialized():
        try:
            if address is None:
                cpus = os.cpu_count() or 2
                ray.init(num_cpus=max(cpus, (workers or 1) + 2), include_dashboard=False,
                         logging_level="WARNING", log_to_driver=False)
            else:
                ray.init(address=address, logging_level="WARNING", log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise UsageError(f"cannot reach a Ray cluster at {address!r}: {exc}".splitlines()[0]) from None
        started = True
    try:
        res = ray.cluster_resources()
        gpus = int(res.get("GPU", 0))
        n = int(workers) if workers else max(1, gpus)
        n = max(1, min(n, len(todo) or 1))
        opts = {"num_gpus": 1, "num_cpus": 0} if gpus else {"num_cpus": 1}
        spare = float(res.get("CPU", 0)) - (0 if gpus else n)
        inline = spare < 1
        report = RunReport(spec, out_dir, "ray", n, todo, redo)
        if not todo:
            return report.finish(manifest)
        Actor = ray.remote(max_restarts=0, **opts)(ShardActor)
        actors = [Actor.remote(spec, str(out_dir), inline) for _ in range(n)]
        alive = []
        for i, a in enumerate(actors):
            try:
                report.add_renderer(ray.get(a.renderer.remote()))
                alive.append(a)
            except ray.exceptions.RayError as exc:
                report.fatal.append(f"worker {i}: {str(exc).splitlines()[0]}")
        queue = list(todo)
        running: dict = {}
        bar = report.progress_bar(progress)

        def assign(actor) -> None:
            if queue:
                k = queue.pop(0)
                running[actor.run_shard.remote(k)] = (actor, k)

        for a in alive:
            assign(a)
        try:
            while running:
                ready, _ = ray.wait(list(running), num_returns=1)
                ref = ready[0]
                actor, k = running.pop(ref)
                try:
                    info = ray.get(ref)
                except ray.exceptions.RayActorError as exc:
                    report.failed[k] = f"worker died ({type(exc).__name__})"
                    continue   # the actor is gone: its queue share goes to the others
                except ray.exceptions.RayError as exc:
                    report.failed[k] = str(exc).strip().splitlines()[-1]
                    assign(actor)
                    continue
                report.shard_done(manifest, info)
                write_manifest(out_dir, manifest)
                bar.update(info["samples"])
                assign(actor)
        finally:
            bar.close()
        for k in queue:
            report.failed.setdefault(k, "not rendered (every worker stopped)")
        for a in actors:
            ray.kill(a)
        return report.finish(manifest)
    finally:
        if started:
            ray.shutdown()
