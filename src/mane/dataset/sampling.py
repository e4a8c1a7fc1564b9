"""What each sample is: its groom, head, colour, camera, lights and simulation, drawn from the
spec with a generator seeded by (spec seed, sample index) through numpy's SeedSequence (the
hairstyle: groom, head and colour, by (spec seed, index // views_per_groom, 1)), so a sample
is the same whichever worker renders it and in whatever order.

    p = sample_params(spec, 12)      # a SampleParams (plain numbers: JSON-able with asdict)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..render.shading.melanin import PRESETS
from .blackbody import blackbody_rgb
from .spec import DatasetSpec


@dataclass(frozen=True)
class SampleParams:
    index: int
    key: str
    groom: int                 # index into spec.grooms
    groom_file: str | None     # a file of that source (None: procedural)
    groom_seed: int
    head: str
    melanin: tuple
    color_preset: str | None
    azimuth: float             # degrees
    elevation: float
    distance: float            # metres
    focal_length: float        # mm
    fov_y: float               # degrees
    jitter: tuple              # metres, added to the look-at target
    lights: tuple              # ((direction xyz), (rgb), intensity, temperature K) per light
    ambient: float
    sim_seconds: float
    motion: str
    wind: tuple                # m/s


def sample_key(index: int) -> str:
    return f"{int(index):09d}"


def sample_rng(seed: int, index: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(index)]))


def _u(rng, r) -> float:
    lo, hi = r
    return float(lo) if lo == hi else float(rng.uniform(lo, hi))


def _direction(azimuth: float, elevation: float) -> tuple:
    az, el = math.radians(azimuth), math.radians(elevation)
    return (math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el))


def sample_params(spec: DatasetSpec, index: int) -> SampleParams:
    """The sample ``index``'s parameters; every draw is made in the same order whatever the spec
    enables, so switching an output on or off changes no other value."""
    from pathlib import Path

    rng = sample_rng(spec.seed, index)
    # the hairstyle (groom, head, colour) is shared by views_per_groom consecutive samples
    style_rng = np.random.default_rng(np.random.SeedSequence([int(spec.seed), int(index) // spec.views_per_groom, 1]))
    w = np.array([g.weight for g in spec.grooms], float)
    gi = int(style_rng.choice(len(spec.grooms), p=w / w.sum()))
    src = spec.grooms[gi]
    seed = int(style_rng.integers(src.seeds[0], src.seeds[1] + 1))
    files = src.files(Path(spec.base_dir))
    gfile = str(files[seed % len(files)].relative_to(spec.base_dir)) if files else None
    head = spec.heads[int(style_rng.integers(len(spec.heads)))]
    c = spec.colors
    pick = int(style_rng.integers(max(len(c.presets), 1)))
    eu, pheo = _u(style_rng, c.eumelanin), _u(style_rng, c.pheomelanin)
    preset = c.presets[pick] if c.presets else None
    melanin = PRESETS[preset] if preset else (eu, pheo)
    v = spec.views
    az, el, dist, focal = _u(rng, v.azimuth), _u(rng, v.elevation), _u(rng, v.distance), _u(rng, v.focal_length)
    jitter = tuple(float(x) for x in rng.uniform(-1.0, 1.0, 3) * v.jitter)
    fov = math.degrees(2.0 * math.atan(v.sensor_height / (2.0 * focal)))
    lt = spec.lights
    count = int(rng.integers(lt.count[0], lt.count[1] + 1))
    lights = []
    for _ in range(4):   # always four draws: the first ``count`` are used
        la, le = _u(rng, lt.azimuth), _u(rng, lt.elevation)
        inten, temp = _u(rng, lt.intensity), _u(rng, lt.temperature)
        lights.append((_direction(la, le), blackbody_rgb(temp), inten, temp))
    ambient = _u(rng, lt.ambient)
    s = spec.simulation
    secs = _u(rng, s.seconds)
    motion = s.motions[int(rng.integers(len(s.motions)))]
    speed, heading = _u(rng, s.wind), float(rng.uniform(0.0, 2.0 * math.pi))
    wind = (speed * math.cos(heading), 0.0, speed * math.sin(heading))
    return SampleParams(index=int(index), key=sample_key(index), groom=gi, groom_file=gfile, groom_seed=seed,
                        head=head, melanin=tuple(melanin), color_preset=preset, azimuth=az, elevation=el,
                        distance=dist, focal_length=focal, fov_y=fov, jitter=jitter, lights=tuple(lights[:count]),
                        ambient=ambient, sim_seconds=secs, motion=motion, wind=wind)
