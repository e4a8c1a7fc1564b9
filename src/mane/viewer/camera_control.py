"""Orbit, pan and zoom: a camera that turns about a target point (no GL here).

    cc = OrbitControl.framing(lo, hi, aspect=16 / 9)
    cc.orbit(dx_pixels, dy_pixels)          # left drag
    cc.pan(dx_pixels, dy_pixels, height)    # right or middle drag: the target follows the mouse
    cc.zoom(wheel_steps)                    # mouse wheel: > 0 comes closer
    camera = cc.camera()                    # a mane.render.Camera

Angles are degrees: azimuth about +Y (0 looks at the face from +Z), elevation above the horizon.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..render.camera import Camera


@dataclass
class OrbitControl:
    target: np.ndarray
    distance: float
    azimuth: float = 25.0
    elevation: float = 10.0
    fov_y: float = 30.0
    radius: float = 0.3
    """the scene's size (m): sets the near and far planes and the zoom limits."""
    orbit_speed: float = 0.3
    """degrees per pixel of drag."""
    zoom_factor: float = 0.9
    """distance multiplier per wheel step toward the target."""

    def __post_init__(self) -> None:
        self.target = np.asarray(self.target, dtype=np.float64).reshape(3).copy()
        self.home = (self.target.copy(), self.distance, self.azimuth, self.elevation)

    @classmethod
    def framing(cls, lo, hi, *, aspect: float, azimuth: float = 25.0, elevation: float = 10.0,
                fov_y: float = 30.0) -> "OrbitControl":
        """A control whose camera sees the box [lo, hi] whole (Camera.framing's distance)."""
        cam = Camera.framing(lo, hi, azimuth=azimuth, elevation=elevation, fov_y=fov_y, aspect=aspect)
        return cls.from_camera(cam, radius=0.5 * float(np.linalg.norm(np.asarray(hi, float) - np.asarray(lo, float))))

    @classmethod
    def from_camera(cls, camera: Camera, radius: float | None = None) -> "OrbitControl":
        eye, target = np.asarray(camera.eye, float), np.asarray(camera.target, float)
        d = eye - target
        dist = float(np.linalg.norm(d))
        az = math.degrees(math.atan2(d[0], d[2]))
        el = math.degrees(math.asin(max(-1.0, min(1.0, d[1] / max(dist, 1e-12)))))
        return cls(target, dist, az, el, camera.fov_y, radius if radius is not None else dist * 0.3)

    # ------------------------------------------------------------------ gestures
    def orbit(self, dx: float, dy: float) -> None:
        """Turn about the target: dx pixels to the right turns the scene right, dy down tilts it."""
        self.azimuth = (self.azimuth - dx * self.orbit_speed) % 360.0
        self.elevation = max(-89.0, min(89.0, self.elevation + dy * self.orbit_speed))

    def pan(self, dx: float, dy: float, viewport_height: int) -> None:
        """Move the target in the view plane so that the scene follows the mouse."""
        metres_per_pixel = 2.0 * self.distance * math.tan(math.radians(self.fov_y) / 2.0) / max(int(viewport_height), 1)
        right, up, _ = self.basis()
        self.target = self.target - right * dx * metres_per_pixel + up * dy * metres_per_pixel

    def zoom(self, steps: float) -> None:
        """Wheel steps: positive comes closer."""
        lo, hi = max(self.radius * 0.05, 1e-3), max(self.radius * 40.0, 1.0)
        self.distance = float(min(hi, max(lo, self.distance * self.zoom_factor ** float(steps))))

    def reset(self) -> None:
        target, self.distance, self.azimuth, self.elevation = self.home
        self.target = target.copy()

    # ------------------------------------------------------------------ results
    def direction(self) -> np.ndarray:
        """Unit vector from the target toward the eye."""
        az, el = math.radians(self.azimuth), math.radians(self.elevation)
        return np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])

    @property
    def eye(self) -> np.ndarray:
        return self.target + self.direction() * self.distance

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, forward) unit vectors of the camera, world frame."""
        f = -self.direction()
        right = np.cross(f, [0.0, 1.0, 0.0])
        n = np.linalg.norm(right)
        right = right / n if n > 1e-9 else np.array([1.0, 0.0, 0.0])
        up = np.cross(right, f)
        return right, up, f

    def camera(self) -> Camera:
        near = max(1e-3, (self.distance - 2.0 * self.radius) * 0.5)
        far = self.distance + 4.0 * self.radius + 1.0
        return Camera(tuple(self.eye), tuple(self.target), (0.0, 1.0, 0.0), self.fov_y, near=near, far=far)
