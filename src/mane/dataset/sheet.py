"""A contact sheet of a data set: one row per sample, RGB | mask | depth | orientation.

Depth: viridis over the sample's hair depths (near yellow, far purple), black where no hair.
Orientation: hue = angle / pi (the colour wheel once around half a turn), brightness = its
confidence, black where no hair.
"""
from __future__ import annotations

import io
import tarfile
from pathlib import Path

import numpy as np

from ..errors import UsageError
from .shards import read_manifest


def sample_rows(out_dir, count: int = 4) -> list[dict]:
    """The first ``count`` samples of a set, decoded: {"rgb", "mask", "depth", "angle", "confidence"}."""
    from PIL import Image

    m = read_manifest(out_dir)
    if m is None:
        raise UsageError(f"no manifest.json in {out_dir}: not a data set")
    need = {"rgb", "mask", "depth", "orientation"}
    if not need <= set(m["outputs"]):
        raise UsageError(f"a contact sheet needs the outputs {', '.join(sorted(need))}; the set has {m['outputs']}")
    rows: dict = {}
    for name in sorted(m["shards"]):
        with tarfile.open(Path(out_dir) / name) as tar:
            for ti in tar:
                key, _, ext = ti.name.partition(".")
                data = tar.extractfile(ti).read()
                if ext.endswith(".png") and ext[:-4] in ("rgb", "mask"):
                    rows.setdefault(key, {})[ext[:-4]] = np.asarray(Image.open(io.BytesIO(data)))
                elif ext in ("depth.npy", "orientation.npy", "orientation_conf.npy"):
                    name_ = {"depth.npy": "depth", "orientation.npy": "angle", "orientation_conf.npy": "confidence"}[ext]
                    rows.setdefault(key, {})[name_] = np.load(io.BytesIO(data)).astype(np.float32)   # angles: float16
        if len(rows) >= count:
            break
    return [rows[k] for k in sorted(rows)[:count]]


def colour_maps(row: dict) -> list[np.ndarray]:
    """The four (H, W, 3) uint8 panels of a sample."""
    import matplotlib

    d, a, c = row["depth"], row["angle"], row["confidence"]
    hit = d > 0
    dn = np.zeros_like(d)
    if hit.any():
        lo, hi = float(d[hit].min()), float(d[hit].max())
        dn[hit] = (d[hit] - lo) / max(hi - lo, 1e-9)
    depth = matplotlib.colormaps["viridis"](1.0 - dn)[..., :3] * hit[..., None]
    hsv = np.stack([a / np.pi, np.ones_like(a), np.clip(c, 0, 1) * hit], axis=-1)
    orient = matplotlib.colors.hsv_to_rgb(np.clip(hsv, 0, 1))
    mask = np.repeat(row["mask"][..., None], 3, axis=-1)
    return [row["rgb"][..., :3], mask, (depth * 255).astype(np.uint8), (orient * 255).astype(np.uint8)]


def contact_sheet(out_dir, path, count: int = 4, gap: int = 2) -> Path:
    """Write the sheet of the first ``count`` samples to ``path`` (PNG)."""
    from PIL import Image

    rows = [np.concatenate(sum(([p, np.full((p.shape[0], gap, 3), 255, np.uint8)] for p in colour_maps(r)), [])[:-1],
                           axis=1) for r in sample_rows(out_dir, count)]
    if not rows:
        raise UsageError(f"{out_dir} has no finished samples")
    w = rows[0].shape[1]
    sheet = np.concatenate(sum(([r, np.full((gap, w, 3), 255, np.uint8)] for r in rows), [])[:-1], axis=0)
    Image.fromarray(sheet).save(path)
    return Path(path)
