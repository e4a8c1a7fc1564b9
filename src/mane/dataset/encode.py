"""The CPU side of a sample: raw arrays -> the files of one WebDataset sample, as bytes. The
.npy / .json / .npz files cost a copy and are made by the GPU worker (encode_arrays); the PNGs
are compressed by encoder processes (encode_pngs), which receive only the arrays they need.

Every encoding is deterministic (no time stamps: the .npz is written with a fixed date), so
the same sample gives the same bytes on every worker and run.
"""
from __future__ import annotations

import io
import json
import zipfile

import numpy as np

from .id_maps import ids
from .spec import DEPTH16_SCALE

FILES = {   # output -> the files (extensions after the key) it writes
    "rgb": ("rgb.png",), "hdr": ("hdr.npy",), "exr": ("rgb_linear.exr",), "mask": ("mask.png",), "depth": ("depth.npy",),
    "depth16": ("depth16.png",), "orientation": ("orientation.npy", "orientation_conf.npy"),
    "ids": ("strand_id.npy", "guide_id.npy"), "camera": ("camera.json",), "strands": ("strands.npz",),
}
FIXED_DATE = (1980, 1, 1, 0, 0, 0)


def expected_files(outputs) -> list[str]:
    return [f for o in outputs for f in FILES[o]]


def png(a: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    img = Image.fromarray(a)   # uint16 (H, W): a 16-bit greyscale PNG
    img.save(buf, format="PNG", compress_level=1)
    return buf.getvalue()


def npy(a: np.ndarray) -> bytearray:
    """The .npy file of ``a`` (format 1.0; what np.save writes), with one copy of the data."""
    a = np.ascontiguousarray(a)
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, np.lib.format.header_data_from_array_1_0(a))
    out = bytearray(buf.getvalue())
    out += memoryview(a).cast("B")
    return out


def npz(arrays: dict) -> bytes:
    """An uncompressed .npz (np.load reads it) with fixed time stamps."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for name, a in arrays.items():
            z.writestr(zipfile.ZipInfo(f"{name}.npy", date_time=FIXED_DATE), npy(a))
    return buf.getvalue()


PNG_OUTPUTS = ("rgb", "mask", "depth16", "exr")   # compressed by the encoder processes


def encode_arrays(raw: dict, outputs) -> dict:
    """The cheap files (.npy, .json, .npz: a header and a copy), made where the sample was
    rendered: {"__key__": key, "depth.npy": bytes, ...}."""
    out: dict = {"__key__": raw["key"]}
    for o in outputs:
        if o == "hdr":
            out["hdr.npy"] = npy(raw["hdr"])
        elif o == "depth":
            out["depth.npy"] = npy(raw["depth"].astype(np.float32, copy=False))
        elif o == "orientation":
            # float16: rounded by at most 2^-10 rad (0.056 degrees) below pi, 2^-12 in [0, 1],
            # far below the degree steps of orientation-map methods (docs/dataset.md); float32
            # values in [0, pi) round to at most 3.140625, so the range stays [0, pi)
            out["orientation.npy"] = npy(raw["angle"].astype(np.float16))
            out["orientation_conf.npy"] = npy(raw["confidence"].astype(np.float16))
        elif o == "ids":
            strands, guides = raw["id_counts"]
            out["strand_id.npy"] = npy(ids(raw["strand"], strands))
            out["guide_id.npy"] = npy(ids(raw["guide"], guides))
        elif o == "camera":
            cam = dict(raw["camera"])
            if "depth16" in outputs:
                cam["depth16_units_per_metre"] = DEPTH16_SCALE
            out["camera.json"] = json.dumps(cam, sort_keys=True, indent=1).encode()
        elif o == "strands":
            out["strands.npz"] = npz(raw["strands"])
    return out


def png_job(raw: dict, outputs) -> dict:
    """What the PNG encoders need of a sample (the arrays only, to keep the hand-over small)."""
    job = {"outputs": [o for o in outputs if o in PNG_OUTPUTS]}
    if "rgb" in outputs:
        job["rgb"] = raw["rgb"]
    if "mask" in outputs:
        job["alpha"] = raw["alpha"]
    if "depth16" in outputs:
        job["depth"] = raw["depth"]
    if "exr" in outputs:
        job["hdr"] = raw["hdr"]
    return job


def exr(rgb: np.ndarray) -> bytes:
    """A half-float RGB OpenEXR (ZIP compression, no time stamps) of (H, W, 3) linear values."""
    import os
    import tempfile

    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    fd, path = tempfile.mkstemp(suffix=".exr")
    os.close(fd)
    try:
        with OpenEXR.File(header, {"RGB": np.ascontiguousarray(rgb, np.float16)}) as f:
            f.write(path)
        with open(path, "rb") as f:
            return f.read()
    finally:
        os.unlink(path)


def encode_pngs(job: dict) -> dict:
    """The compressed images of a sample, PNGs and the EXR (the CPU-heavy part, run by encoder
    processes)."""
    out = {}
    for o in job["outputs"]:
        if o == "rgb":
            out["rgb.png"] = png(job["rgb"])
        elif o == "mask":
            out["mask.png"] = png(np.round(np.clip(job["alpha"], 0.0, 1.0) * 255.0).astype(np.uint8))
        elif o == "depth16":
            out["depth16.png"] = png(np.round(np.clip(job["depth"] * DEPTH16_SCALE, 0, 65535)).astype(np.uint16))
        elif o == "exr":
            out["rgb_linear.exr"] = exr(job["hdr"])
    return out


def encode_sample(raw: dict, outputs) -> dict:
    """Every file of a sample: {"__key__": key, "rgb.png": bytes, ...} for the chosen outputs."""
    return {**encode_arrays(raw, outputs), **encode_pngs(png_job(raw, outputs))}
