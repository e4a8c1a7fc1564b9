"""Wind: a mean wind plus gusts that travel with it.

The wind velocity is evaluated once per strand (at its root) and time, on the GPU in
``wind.glsl``; the force it makes is plain linear drag toward it (see ``SimSettings.drag``):

    a_drag = drag * (w(strand, t) - v)            drag in 1/s, velocities in m/s

    w(s, t) = U * (1 + gust * n0(tau)) + turbulence * (n1(tau), n2(tau), n3(tau))
    tau     = frequency * (t - dot(root_s, U/|U|) / max(|U|, 0.5 m/s)) + jitter * h(s)

``U`` is the mean wind, ``n_j`` is an fBm of 1-D value noise (a PCG integer hash per
lattice point, smoothstep between them, ``octaves`` octaves halving in amplitude and
doubling in frequency) in [-1, 1], one independent channel per j. ``tau`` shifts with
the root's position along the wind, so a gust sweeps across the head at the wind's
speed (frozen turbulence) instead of hitting every strand at once; ``h(s)`` in [0, 1)
is a per-strand hash that de-synchronises neighbours by up to ``jitter`` noise periods.

``gust_field(...)`` is the same formula in NumPy (float32, bit-for-bit hash), used to
draw or inspect the field and by the tests.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..setting import setting, validate

MAX_WIND_SPEED = 500.0
"""Largest peak wind speed accepted, m/s (|velocity| (1 + gust) + turbulence)."""


@dataclass(frozen=True)
class WindSettings:
    """Wind felt by the hair (it acts only through ``SimSettings.drag``)."""

    velocity: tuple[float, float, float] = setting((0.0, 0.0, 0.0), lo=-MAX_WIND_SPEED, hi=MAX_WIND_SPEED, unit="m/s",
        help="mean wind velocity U, m/s (world frame).")
    gust: float = setting(0.0, lo=0.0, hi=10.0, slider=(0.0, 3.0),
        help="gust strength: fraction of |U| by which the wind speed swings (dimensionless, >= 0).")
    turbulence: float = setting(0.0, lo=0.0, hi=MAX_WIND_SPEED, unit="m/s", slider=(0.0, 3.0),
        help="amplitude of the direction-free turbulent part, m/s (>= 0).")
    frequency: float = setting(0.5, lo=0.0, lo_open=True, hi=1000.0, unit="Hz", slider=(0.05, 5.0),
        help="lowest gust frequency, Hz (> 0).")
    octaves: int = setting(3, lo=1, hi=8,
        help="fBm octaves of the gust noise (1..8).")
    jitter: float = setting(0.25, lo=0.0, hi=1000.0, slider=(0.0, 2.0),
        help="per-strand phase spread, in noise periods (>= 0).")
    seed: int = setting(0, lo=-(2**63), hi=2**63 - 1,
        help="noise seed (any int; taken modulo 2**32).")

    def __post_init__(self) -> None:
        validate(self, "wind.")   # every field against its declaration (mane.setting)
        with np.errstate(over="ignore"):
            peak = float(np.linalg.norm(self.velocity)) * (1.0 + self.gust) + self.turbulence
        if peak > MAX_WIND_SPEED:
            raise UsageError(f"wind of up to {peak:.3g} m/s (velocity, gusts and turbulence) is beyond the "
                             f"{MAX_WIND_SPEED:g} m/s the solver handles (hurricanes blow ~80 m/s)")

    @property
    def active(self) -> bool:
        return any(self.velocity) or self.turbulence > 0

    def uniforms(self) -> dict:
        """The values ``wind.glsl`` reads, by uniform name."""
        return {
            "wind_velocity": self.velocity,
            "wind_gust": self.gust,
            "wind_turbulence": self.turbulence,
            "wind_frequency": float(self.frequency),
            "wind_octaves": self.octaves,
            "wind_jitter": self.jitter,
            "wind_seed": int(self.seed) % 2**32,
        }


# ---------------------------------------------------------------------- NumPy version
_U32 = np.uint32


def pcg_hash(v) -> np.ndarray:
    """PCG output hash of uint32 values (Jarzynski & Olano 2020), as in wind.glsl."""
    with np.errstate(over="ignore"):
        v = np.asarray(v, dtype=np.uint32)
        state = v * _U32(747796405) + _U32(2891336453)
        word = ((state >> ((state >> _U32(28)) + _U32(4))) ^ state) * _U32(277803737)
        return (word >> _U32(22)) ^ word


def _hash_signed(i, seed) -> np.ndarray:
    """A hash of lattice index i and seed as float32 in [-1, 1]."""
    with np.errstate(over="ignore"):
        h = pcg_hash(np.asarray(i, dtype=np.uint32) ^ pcg_hash(seed))
    return (h >> _U32(8)).astype(np.float32) * np.float32(2.0 / 16777215.0) - np.float32(1.0)


def value_noise(tau, seed) -> np.ndarray:
    tau = np.asarray(tau, dtype=np.float32)
    f = np.floor(tau)
    i = f.astype(np.int64).astype(np.uint32)  # two's complement, as uint(int(x)) in GLSL
    t = tau - f
    s = t * t * (np.float32(3.0) - np.float32(2.0) * t)
    with np.errstate(over="ignore"):
        a, b = _hash_signed(i, seed), _hash_signed(i + _U32(1), seed)
    return a + (b - a) * s


def fbm(tau, seed, octaves: int) -> np.ndarray:
    tau = np.asarray(tau, dtype=np.float32)
    total = np.zeros_like(tau)
    amp, norm = np.float32(1.0), np.float32(0.0)
    for o in range(octaves):
        with np.errstate(over="ignore"):
            s = _U32(seed) + _U32(o) * _U32(1013)
        total = total + amp * value_noise(tau * np.float32(2.0**o), s)
        norm += amp
        amp = amp * np.float32(0.5)
    return total / norm


def strand_hash01(strand) -> np.ndarray:
    return (pcg_hash(np.asarray(strand, dtype=np.uint32) + _U32(0x9E3779B9)) >> _U32(8)).astype(
        np.float32) * np.float32(1.0 / 16777216.0)


def gust_field(wind: WindSettings, roots: np.ndarray, strands: np.ndarray, t: float) -> np.ndarray:
    """(S, 3) float32 wind velocity w(s, t) at the given roots (S, 3) of strands (S,)."""
    U = np.asarray(wind.velocity, dtype=np.float32)
    speed = np.float32(np.linalg.norm(U))
    direction = U / speed if speed > 0 else np.zeros(3, np.float32)
    roots = np.asarray(roots, dtype=np.float32)
    along = roots @ direction
    tau = np.float32(wind.frequency) * (np.float32(t) - along / max(speed, np.float32(0.5)))
    tau = tau + np.float32(wind.jitter) * strand_hash01(strands)
    seed = np.uint32(int(wind.seed) % 2**32)
    with np.errstate(over="ignore"):
        n = [fbm(tau, seed + _U32(j) * _U32(7919), wind.octaves) for j in range(4)]
    w = U[None, :] * (np.float32(1.0) + np.float32(wind.gust) * n[0])[:, None]
    w = w + np.float32(wind.turbulence) * np.stack(n[1:], axis=1)
    return w.astype(np.float32)
