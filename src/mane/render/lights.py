"""Lights: directional or point, with a linear RGB colour and an intensity.

``direction`` points from the scene toward the light (the L vector of shading). Light 0 is the
key light: it always casts shadows; RenderSettings.shadow_lights makes the first few cast. At most ``MAX_LIGHTS`` lights are shaded.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

MAX_LIGHTS = 4
MAX_SHADOW_LIGHTS = 4
KINDS = ("directional", "point")


@dataclass(frozen=True)
class Light:
    kind: str = "directional"
    vector: tuple[float, float, float] = (0.4, 0.8, 0.6)
    """directional: direction toward the light (normalised on use); point: position (m)."""
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    """Linear RGB."""
    intensity: float = 3.0
    """Radiance scale (directional) or radiant intensity at 1 m (point, falls off as 1/d^2)."""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise UsageError(f"light kind must be one of {KINDS}, got {self.kind!r}")
        v = tuple(float(x) for x in self.vector)
        c = tuple(float(x) for x in self.color)
        if len(v) != 3 or len(c) != 3 or not np.all(np.isfinite(v + c)):
            raise UsageError("a light needs 3 finite numbers for its vector and its colour")
        if self.kind == "directional" and not np.linalg.norm(v) > 0:
            raise UsageError("a directional light's direction cannot be zero")
        if min(c) < 0:
            raise UsageError(f"a light's colour must be >= 0 (linear RGB), got {c}")
        if not (math.isfinite(float(self.intensity)) and float(self.intensity) >= 0):
            raise UsageError(f"light intensity must be a finite number >= 0, got {self.intensity}")
        object.__setattr__(self, "vector", v)
        object.__setattr__(self, "color", c)

    @property
    def is_point(self) -> bool:
        return self.kind == "point"

    def direction_to(self, center) -> np.ndarray:
        """Unit direction from ``center`` toward the light."""
        if self.is_point:
            d = np.asarray(self.vector, float) - np.asarray(center, float)
        else:
            d = np.asarray(self.vector, float)
        n = np.linalg.norm(d)
        return d / n if n > 0 else np.array([0.0, 1.0, 0.0])


def default_lights() -> list[Light]:
    """Key (warm, from the upper front left, casts shadows), fill (cool, right) and rim (behind)."""
    return [
        Light("directional", (-0.45, 0.75, 0.55), (1.0, 0.96, 0.9), 2.4),
        Light("directional", (0.8, 0.15, 0.5), (0.75, 0.82, 1.0), 0.6),
        Light("directional", (0.1, 0.5, -1.0), (1.0, 1.0, 1.0), 0.9),
    ]


def parse_light(text: str) -> Light:
    """--light "dir:X,Y,Z[:INTENSITY[:R,G,B]]" or "point:X,Y,Z[:INTENSITY[:R,G,B]]"."""
    parts = text.split(":")
    try:
        kind = {"dir": "directional", "directional": "directional", "point": "point"}[parts[0].strip().lower()]
        vec = tuple(float(v) for v in parts[1].split(","))
        intensity = float(parts[2]) if len(parts) > 2 and parts[2] else (3.0 if kind == "directional" else 1.0)
        color = tuple(float(v) for v in parts[3].split(",")) if len(parts) > 3 else (1.0, 1.0, 1.0)
        if len(parts) > 4:
            raise ValueError("too many fields")
        return Light(kind, vec, color, intensity)
    except (KeyError, IndexError, ValueError) as exc:
        raise UsageError(f"bad --light {text!r} ({exc}); use dir:X,Y,Z[:INTENSITY[:R,G,B]] "
                         "or point:X,Y,Z[:INTENSITY[:R,G,B]]") from None
