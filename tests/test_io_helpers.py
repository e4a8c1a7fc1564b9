"""Shared builders for the io tests: sample grooms and spec-built files (struct/NumPy only)."""
from __future__ import annotations

import struct

import numpy as np

from mane import Groom


def sample_groom(counts=(3, 5, 2, 4), seed=0, widths=True, colors=True, transparency=True,
                 attrs=True) -> Groom:
    rng = np.random.default_rng(seed)
    counts = np.asarray(counts)
    P = int(counts.sum())
    pts = rng.normal(size=(P, 3)).astype(np.float32)
    kw = {}
    if widths:
        kw["widths"] = rng.uniform(1e-5, 1e-4, P).astype(np.float32)
    if colors:
        kw["colors"] = rng.uniform(0, 1, (P, 3)).astype(np.float32)
    if transparency:
        kw["transparency"] = rng.uniform(0, 1, P).astype(np.float32)
    if attrs:
        imm = np.zeros(P, bool)
        imm[np.cumsum(counts) - counts] = True
        kw["point_attributes"] = {"immovable": imm}
        kw["strand_attributes"] = {"guide": np.arange(len(counts), dtype=np.int32)}
    return Groom(pts, counts, **kw)


def cyhair_bytes(points, counts=None, d_segments=0, thickness=None, transparency=None,
                 colors=None, d_thickness=1.0, d_transparency=0.0, d_color=(1.0, 1.0, 1.0),
                 info=b"", hair_count=None, point_count=None, arrays=None) -> bytes:
    """A .hair file built from the spec table in ../shared/research/formats.md."""
    points = np.asarray(points, "<f4").reshape(-1, 3)
    bits = 2
    body = b""
    if counts is not None:
        bits |= 1
        body += (np.asarray(counts) - 1).astype("<u2").tobytes()
    body += points.tobytes()
    for bit, arr in ((4, thickness), (8, transparency), (16, colors)):
        if arr is not None:
            bits |= bit
            body += np.asarray(arr, "<f4").tobytes()
    hc = hair_count if hair_count is not None else (len(counts) if counts is not None
                                                     else len(points) // (d_segments + 1))
    pc = point_count if point_count is not None else len(points)
    header = b"HAIR" + struct.pack("<IIII", hc, pc, bits if arrays is None else arrays, d_segments)
    header += struct.pack("<ff3f", d_thickness, d_transparency, *d_color) + info.ljust(88, b"\0")
    assert len(header) == 128
    return header + body


def usc_bytes(strands) -> bytes:
    out = struct.pack("<i", len(strands))
    for s in strands:
        s = np.asarray(s, "<f4").reshape(-1, 3)
        out += struct.pack("<i", len(s)) + s.tobytes()
    return out


def tfx4_bytes(pos4, strands, verts, strand_uv=None, vertex_uv=None, thickness=None,
               vertex_color=None) -> bytes:
    blobs, offsets, at = [], [], 160
    for arr in (pos4, strand_uv, vertex_uv, thickness, vertex_color):
        if arr is None:
            offsets.append(0)
            continue
        raw = np.asarray(arr, "<f4").tobytes()
        offsets.append(at)
        blobs.append(raw)
        at += len(raw)
    header = struct.pack("<f7I", 4.0, strands, verts, *offsets) + b"\0" * 128
    return header + b"".join(blobs)


def tfx3_bytes(pos3, strands, verts, both_ends=0, follow=0, thickness=None, strand_uv=None) -> bytes:
    pos3 = np.asarray(pos3, "<f4").tobytes()
    offsets = [296, 0, 0, 0, 0, 0]
    tail = b""
    at = 296 + len(pos3)
    if thickness is not None:
        offsets[1] = at
        raw = np.asarray(thickness, "<f4").tobytes()
        tail += raw
        at += len(raw)
    if strand_uv is not None:
        offsets[2] = at
        raw = np.asarray(strand_uv, "<f4").tobytes()
        tail += raw
        at += len(raw)
    header = struct.pack("<f4I", 3.0, strands, verts, follow, both_ends) + b"\0" * (31 * 4)
    header += struct.pack("<6I", *offsets) + b"\0" * 128
    assert len(header) == 296
    return header + pos3 + tail
