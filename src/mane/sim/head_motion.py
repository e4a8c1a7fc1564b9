"""Head motion presets: rigid 4x4 transforms (head frame -> world) as functions of time.

    m = nod(t)                 # rotation about the x axis through the pivot, swinging
    m = shake(t)               # about the y axis
    m = turn(t)                # a smooth quarter turn about y and back, every period
    sim.set_head_transform(preset("nod")(t))

Angles in radians, frequencies in Hz, pivots in metres (the neck: put it below the head).
``interpolate(a, b, t)`` blends two rigid transforms (slerp + lerp) for sub-steps.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..errors import UsageError


def rotation(axis, angle: float) -> np.ndarray:
    """4x4 rotation by ``angle`` radians about the unit ``axis`` through the origin."""
    a = np.asarray(axis, dtype=np.float64).reshape(3)
    a = a / np.linalg.norm(a)
    c, s = math.cos(angle), math.sin(angle)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * K + (1 - c) * np.outer(a, a)
    return m


def about_pivot(m: np.ndarray, pivot) -> np.ndarray:
    """``m`` applied about ``pivot`` instead of the origin."""
    p = np.asarray(pivot, dtype=np.float64).reshape(3)
    t1, t2 = np.eye(4), np.eye(4)
    t1[:3, 3], t2[:3, 3] = p, -p
    return t1 @ m @ t2


def nod(t: float, amplitude: float = math.radians(20), frequency: float = 0.5,
        pivot=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Nodding: rotation about x by amplitude * sin(2 pi f t)."""
    return about_pivot(rotation((1, 0, 0), amplitude * math.sin(2 * math.pi * frequency * t)), pivot)


def shake(t: float, amplitude: float = math.radians(30), frequency: float = 0.7,
          pivot=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Shaking 'no': rotation about y by amplitude * sin(2 pi f t)."""
    return about_pivot(rotation((0, 1, 0), amplitude * math.sin(2 * math.pi * frequency * t)), pivot)


def turn(t: float, angle: float = math.radians(90), period: float = 3.0,
         pivot=(0.0, 0.0, 0.0)) -> np.ndarray:
    """A quick turn about y to ``angle`` and back, smooth (C1), repeating every ``period`` s:
    turn over the first quarter, hold, turn back over the third quarter, hold."""
    u = (t % period) / period
    if u < 0.25:
        w = _smooth(u / 0.25)
    elif u < 0.5:
        w = 1.0
    elif u < 0.75:
        w = 1.0 - _smooth((u - 0.5) / 0.25)
    else:
        w = 0.0
    return about_pivot(rotation((0, 1, 0), angle * w), pivot)


def still(t: float, **_) -> np.ndarray:
    return np.eye(4)


def _smooth(x: float) -> float:
    return x * x * (3 - 2 * x)


PRESETS: dict[str, Callable[..., np.ndarray]] = {"none": still, "nod": nod, "shake": shake, "turn": turn}


def preset(name: str, **params) -> Callable[[float], np.ndarray]:
    """The motion ``name`` (none, nod, shake, turn) as a function of time, with ``params`` bound."""
    try:
        f = PRESETS[name]
    except KeyError:
        raise UsageError(f"unknown head motion {name!r}; choose one of {', '.join(PRESETS)}") from None
    return lambda t: f(t, **params)


def interpolate(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """Rigid blend of two 4x4 transforms: slerp of the rotations, lerp of the translations.

    Transforms that are not rigid (scale, shear) are blended element by element.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if t <= 0.0:
        return a.copy()
    if t >= 1.0:
        return b.copy()
    ra, rb = a[:3, :3], b[:3, :3]
    rigid = all(np.allclose(r.T @ r, np.eye(3), atol=1e-5) and np.linalg.det(r) > 0 for r in (ra, rb))
    if not rigid:
        return a + (b - a) * t
    from scipy.spatial.transform import Rotation, Slerp

    rot = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([ra, rb])))([t]).as_matrix()[0]
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = a[:3, 3] + (b[:3, 3] - a[:3, 3]) * t
    return m
