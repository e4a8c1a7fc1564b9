"""Hypothesis fuzzing of every loader: random bytes, and mutations / truncations of valid files.

Whatever the bytes, a loader either returns a Groom (or Mesh) or raises a ManeError: nothing
else may escape, nothing may crash the interpreter or hang. The valid seed files come from
the writers (and, for read-only formats, from the spec-built helpers).
"""
from __future__ import annotations

import struct
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mane
from mane import Groom, ManeError
from mane.io import alembic_curves, usd_curves
from mane.mesh import Mesh
from test_io_helpers import sample_groom, tfx3_bytes

_TMP = tempfile.TemporaryDirectory(prefix="mane-fuzz-")
TMP = Path(_TMP.name)

INTERESTING = [0, 1, 2, 3, 0x7F, 0xFF, 0xFFFF, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 0x10000]


@lru_cache(maxsize=None)
def seed_bytes(suffix: str) -> bytes:
    """A small valid file of each format."""
    g = sample_groom([3, 2, 4], seed=11)
    path = TMP / f"seed{suffix}"
    if suffix == ".tfx":
        mane.save(sample_groom([4, 4, 4], seed=11).replace(
            strand_attributes={"uv": np.float32([[0, 1], [1, 0], [0.5, 0.5]])}), path)
    elif suffix == ".tfx3":
        return tfx3_bytes(np.arange(36, dtype=np.float32).reshape(-1, 3), 3, 4, both_ends=1,
                          thickness=[1, 2, 3])
    elif suffix == ".tfxproj":
        return (b"Version 3.0\nproject_name x\npart.tfx 4 0.4 5.0 p.tfxsim part\n"
                b"m.sdkmesh\ncollision_sphere 1 2 3 4\nhairColor 1 0 0\n")
    elif suffix == ".plya":
        from mane.io import strand_ply

        strand_ply.write(g, path, binary=False)
    elif suffix in (".obj", ".stl", ".glb", ".plym"):
        import trimesh

        mesh = trimesh.creation.icosphere(subdivisions=1)
        if suffix == ".plym":
            return trimesh.exchange.ply.export_ply(mesh, encoding="binary")
        out = mesh.export(file_type=suffix[1:])
        return out.encode() if isinstance(out, str) else out
    elif suffix == ".tfxmesh":
        return (b"numOfBones 1\n0 root\nnumOfVertices 3\n"
                b"0 0 0 0 0 0 1 0 0 0 0 1 0 0 0\n1 1 0 0 0 0 1 0 0 0 0 1 0 0 0\n"
                b"2 0 1 0 0 0 1 0 0 0 0 1 0 0 0\nnumOfTriangles 1\n0 0 1 2\n")
    else:
        mane.save(g, path)
    data = path.read_bytes()
    assert data
    return data


@st.composite
def mutated(draw, base: bytes):
    """A valid file, changed: bytes flipped, 32-bit fields overwritten, cut, spliced.

    Positions come from a seeded uniform generator (Hypothesis's own integers cluster at
    small values, which would mostly break the magic number and never reach the body).
    """
    rnd = draw(st.randoms(use_true_random=False))
    data = bytearray(base)
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["flip", "u32", "u32", "truncate", "delete", "insert", "dup"]))
        n = len(data)
        if n == 0:
            break
        at = rnd.randrange(n)
        if kind == "flip":
            data[at] ^= 1 << rnd.randrange(8)
        elif kind == "u32":
            at -= at % 4
            value = draw(st.sampled_from(INTERESTING)) if rnd.random() < 0.7 else rnd.getrandbits(32)
            data[at:at + 4] = struct.pack("<I", value)
        elif kind == "truncate":
            del data[at:]
        elif kind == "delete":
            del data[at:at + rnd.randrange(1, 17)]
        elif kind == "insert":
            data[at:at] = rnd.randbytes(rnd.randrange(1, 17))
        else:
            data[at:at] = data[at:at + rnd.randrange(1, 65)]
    return bytes(data)


def inputs(suffix: str, magic: bytes = b""):
    base = seed_bytes(suffix)
    random = st.binary(max_size=512)
    if magic:
        random = random | st.binary(max_size=512).map(lambda b: magic + b)
    return random | mutated(base) | mutated(base) | mutated(base)


def check(loader, path: Path, data: bytes, **kw):
    path.write_bytes(data)
    try:
        result = loader(path, **kw)
    except ManeError as exc:
        assert str(exc)  # every error says something
        return
    assert isinstance(result, (Groom, Mesh))


FAST = settings(max_examples=200, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
# a child process per example (~0.4 s with usd-core): 60 keep both USD readers' fuzzing under a
# minute together inside make test's 15-minute budget on 2 cores
SLOW = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# (name on disk, seed key, magic)
HAIR = [
    ("f.hair", ".hair", b"HAIR"),
    ("f.data", ".data", b""),
    ("f.tfx", ".tfx", struct.pack("<f", 4.0)),
    ("g.tfx", ".tfx3", struct.pack("<f", 3.0)),
    ("f.ply", ".ply", b"ply\nformat binary_little_endian 1.0\n"),
    ("g.ply", ".plya", b"ply\nformat ascii 1.0\n"),
    ("f.npz", ".npz", b"PK\x03\x04"),
]


@pytest.mark.parametrize("name,key,magic", HAIR, ids=[h[1] for h in HAIR])
@pytest.mark.slow
def test_fuzz_hair_loader(name, key, magic):
    path = TMP / name

    @FAST
    @given(inputs(key, magic))
    def run(data):
        check(mane.load, path, data)

    run()


@pytest.mark.slow
def test_fuzz_tfxproj():
    folder = TMP / "proj"
    folder.mkdir(exist_ok=True)
    mane.save(sample_groom([4, 4], seed=2), folder / "part.tfx")
    path = folder / "p.tfxproj"

    @FAST
    @given(inputs(".tfxproj") | st.text(max_size=300).map(lambda t: t.encode("utf-8")))
    def run(data):
        check(mane.load, path, data)

    run()


MESH = [("f.obj", ".obj", b"v "), ("f.stl", ".stl", b"solid "), ("f.glb", ".glb", b"glTF\x02\0\0\0"),
        ("f.ply", ".plym", b"ply\nformat binary_little_endian 1.0\n"), ("f.tfxmesh", ".tfxmesh", b"numOfBones ")]


@pytest.mark.parametrize("name,key,magic", MESH, ids=[m[1] for m in MESH])
@pytest.mark.slow
def test_fuzz_mesh_loader(name, key, magic):
    folder = TMP / "mesh"
    folder.mkdir(exist_ok=True)
    path = folder / name

    @FAST
    @given(inputs(key, magic))
    def run(data):
        check(mane.load_mesh, path, data)

    run()


# The library-backed readers run in a child process; fewer examples, a short time limit.
@pytest.mark.parametrize("name,key,magic,reader", [
    ("f.usda", ".usda", b"#usda 1.0\n", usd_curves.read),
    ("f.usdc", ".usdc", b"PXR-USDC", usd_curves.read),
    ("f.abc", ".abc", b"Ogawa\xff\x00\x01", alembic_curves.read),
], ids=[".usda", ".usdc", ".abc"])
@pytest.mark.slow
def test_fuzz_library_loader(name, key, magic, reader):
    path = TMP / name

    @SLOW
    @given(inputs(key, magic))
    def run(data):
        check(reader, path, data, timeout=30)

    run()
