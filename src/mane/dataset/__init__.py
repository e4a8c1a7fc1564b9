"""Hair data sets at scale: a TOML spec -> WebDataset shards of rendered samples with ground truth
(RGB, mask, depth, 2D orientation, strand and guide ids, camera, strands), locally or on Ray.

    from mane.dataset import load_spec, run_local, verify
    spec = load_spec("examples/dataset_tiny.toml")
    report = run_local(spec, "/tmp/tiny")      # or mane.dataset.ray_runner.run_ray
    verify("/tmp/tiny")["ok"]

The package orchestrates only; the maps are rendered by mane.render.aux_maps.
"""
from __future__ import annotations

from .spec import DatasetSpec, load_spec, parse_spec  # noqa: F401


def __getattr__(name):
    if name == "run_local":
        from .local import run_local

        return run_local
    if name == "verify":
        from .shards import verify

        return verify
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["DatasetSpec", "load_spec", "parse_spec", "run_local", "verify"]
