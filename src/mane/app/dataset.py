"""``mane dataset plan|run|verify``: make hair data sets (WebDataset shards + manifest).

    mane dataset plan examples/dataset_tiny.toml
    mane dataset run examples/dataset_tiny.toml --out /tmp/tiny            # this machine, no server
    mane dataset run examples/dataset_tiny.toml --out /tmp/tiny --ray      # a local Ray cluster
    mane dataset run SPEC --out DIR --ray auto                             # an existing cluster
    mane dataset verify /tmp/tiny
    mane dataset sheet /tmp/tiny --out sheet.png                            # look at it
"""
from __future__ import annotations

import argparse
import json

HELP = "make hair data sets: plan a spec, run it (locally or on Ray) into WebDataset shards, verify a set"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    p = sub.add_parser("plan", help="print the samples, shards and estimated disk of a spec")
    p.add_argument("spec", help="dataset spec (.toml)")
    p.add_argument("--json", action="store_true", help="print the plan as JSON")
    r = sub.add_parser("run", help="render a spec into DIR (resumes: finished shards are kept)")
    r.add_argument("spec", help="dataset spec (.toml)")
    r.add_argument("--out", required=True, metavar="DIR", help="output folder (shards + manifest.json)")
    r.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                   help="run on Ray: no ADDRESS starts a local cluster, 'auto' joins a running one "
                        "(ray start --head), or ray://host:port")
    r.add_argument("--workers", type=int, default=None, metavar="N",
                   help="GPU workers (default: one per visible GPU, at least 1; on Ray without GPUs: 1)")
    r.add_argument("--encoders", type=int, default=None, metavar="N",
                   help="local: CPU encoder processes per GPU worker (0: encode in the worker; default: "
                        "cores / workers - 1)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--report", metavar="FILE", help="write the run's report as JSON")
    c = sub.add_parser("sheet", help="a contact sheet PNG of a set's first samples: RGB | mask | depth | orientation")
    c.add_argument("dir", help="the data set folder")
    c.add_argument("--out", required=True, metavar="PNG", help="the sheet to write")
    c.add_argument("--count", type=int, default=4, help="samples (rows), default 4")
    v = sub.add_parser("verify", help="check a set: manifest, checksums, counts, files, decoding")
    v.add_argument("dir", help="the data set folder")
    v.add_argument("--no-decode", action="store_true", help="skip decoding every file (checksums and layout only)")


def run(args) -> int:
    from ..dataset import load_spec

    if args.action == "plan":
        from ..dataset.spec import estimate_bytes

        spec = load_spec(args.spec)
        est = estimate_bytes(spec)
        plan = {"name": spec.name, "samples": spec.samples, "shards": spec.num_shards,
                "samples_per_shard": spec.samples_per_shard, "size": list(spec.size), "outputs": list(spec.outputs),
                "bytes_per_sample": est["per_sample"], "bytes_total": est["total"], "spec_hash": spec.hash()}
        if args.json:
            print(json.dumps(plan, indent=1))
        else:
            print(f"{spec.name}: {spec.samples} samples of {spec.size[0]}x{spec.size[1]} in {spec.num_shards} "
                  f"shard(s) of up to {spec.samples_per_shard}; outputs {', '.join(spec.outputs)}")
            print(f"estimated disk: {_human(est['total'])} ({_human(est['per_sample'])} a sample)")
        return 0
    if args.action == "sheet":
        from ..dataset.sheet import contact_sheet

        print(f"wrote {contact_sheet(args.dir, args.out, max(1, args.count))}")
        return 0
    if args.action == "verify":
        from ..dataset.shards import verify

        rep = verify(args.dir, decode=not args.no_decode)
        for p in rep["problems"]:
            print(f"mane dataset verify: {p}")
        print(f"{'OK' if rep['ok'] else 'FAILED'}: {rep['shards']} shard(s), {rep['samples']} samples verified "
              f"in {args.dir}")
        return 0 if rep["ok"] else 1
    spec = load_spec(args.spec)
    if args.workers is not None and args.workers < 1:
        from ..errors import UsageError

        raise UsageError("--workers must be >= 1")
    if args.ray is not None:
        from ..dataset.ray_runner import run_ray

        report = run_ray(spec, args.out, address=None if args.ray == "local" else args.ray, workers=args.workers,
                         progress=not args.no_progress)
    else:
        from ..dataset.local import run_local

        report = run_local(spec, args.out, workers=args.workers, encoders=args.encoders,
                           progress=not args.no_progress)
    for line in report.lines():
        print(line)
    if args.report:
        from pathlib import Path

        Path(args.report).write_text(json.dumps(report.as_dict(), indent=1))
    return 0 if report.ok else 1


def _human(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1000.0
    return f"{n:.1f} TB"
