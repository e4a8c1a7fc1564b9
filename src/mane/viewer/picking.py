"""Picking the collision sphere and the lights' handles with the mouse, and dragging them (no GL here).

    ray = pixel_ray(camera, x, y, width, height)          # window pixels, top-left origin
    t = ray_sphere(ray, centre, radius)                   # distance along the ray, or None
    drag = PlaneDrag.start(ray, centre, camera.forward)   # the plane through the centre, facing the camera
    new_centre = drag.move(pixel_ray(camera, x2, y2, width, height))
    turn = SphereDrag.start(ray, centre, radius, handle)  # a handle on a sphere about centre
    direction = turn.move(pixel_ray(camera, x2, y2, width, height))   # unit, from the centre

``keyboard_offset`` turns W/A/S/D/Q/E into a displacement in the camera's frame (as in the
Vulkan hair demo: W/S forward and back, A/D left and right, Q/E down and up).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..render.camera import Camera


@dataclass(frozen=True)
class Ray:
    origin: np.ndarray
    direction: np.ndarray   # unit

    def at(self, t: float) -> np.ndarray:
        return self.origin + self.direction * float(t)


def pixel_ray(camera: Camera, x: float, y: float, width: int, height: int) -> Ray:
    """The ray from the eye through window pixel (x, y) (top-left origin, y down)."""
    w, h = max(int(width), 1), max(int(height), 1)
    ndc_x = 2.0 * (float(x) + 0.5) / w - 1.0
    ndc_y = 1.0 - 2.0 * (float(y) + 0.5) / h
    ty = math.tan(math.radians(camera.fov_y) / 2.0)
    tx = ty * w / h
    view = camera.view()          # world -> view; rows are right, up, -forward
    right, up, back = view[0, :3], view[1, :3], view[2, :3]
    d = right * ndc_x * tx + up * ndc_y * ty - back
    return Ray(np.asarray(camera.eye, np.float64), d / np.linalg.norm(d))


def project(camera: Camera, point, width: int, height: int) -> tuple[float, float]:
    """World point -> window pixel (x, y), top-left origin (the inverse of pixel_ray)."""
    p = np.append(np.asarray(point, np.float64), 1.0)
    clip = camera.view_projection(width / height) @ p
    ndc = clip[:3] / clip[3]
    return ((ndc[0] + 1.0) * 0.5 * width - 0.5, (1.0 - ndc[1]) * 0.5 * height - 0.5)


def in_front(camera: Camera, point) -> bool:
    """True when ``point`` lies in front of the camera (past its near plane)."""
    d = np.asarray(point, np.float64) - np.asarray(camera.eye, np.float64)
    return float(np.dot(d, camera.forward)) > float(camera.near)


def ray_sphere(ray: Ray, center, radius: float) -> float | None:
    """Distance along ``ray`` to the first hit of the sphere (0 when the origin is inside), or None."""
    hits = ray_sphere_hits(ray, center, radius)
    if hits is None or hits[1] < 0:
        return None
    return max(hits[0], 0.0)


def ray_sphere_hits(ray: Ray, center, radius: float) -> tuple[float, float] | None:
    """Both distances along ``ray`` where its line crosses the sphere (t0 <= t1), or None."""
    oc = ray.origin - np.asarray(center, np.float64)
    b = float(np.dot(oc, ray.direction))
    c = float(np.dot(oc, oc)) - float(radius) ** 2
    disc = b * b - c
    if disc < 0:
        return None
    s = math.sqrt(disc)
    return -b - s, -b + s


def closest_on_ray(ray: Ray, point) -> np.ndarray:
    """The point of the ray (t >= 0) nearest ``point``."""
    t = max(float(np.dot(np.asarray(point, np.float64) - ray.origin, ray.direction)), 0.0)
    return ray.at(t)


def ray_plane(ray: Ray, point, normal) -> float | None:
    n = np.asarray(normal, np.float64)
    denom = float(np.dot(ray.direction, n))
    if abs(denom) < 1e-9:
        return None
    t = float(np.dot(np.asarray(point, np.float64) - ray.origin, n)) / denom
    return t if t >= 0 else None


@dataclass
class PlaneDrag:
    """Dragging on the plane through the grabbed object's centre that faces the camera; the
    grabbed point keeps its offset from the centre."""

    point: np.ndarray      # a point of the plane
    normal: np.ndarray
    offset: np.ndarray     # centre - grabbed point

    @classmethod
    def start(cls, ray: Ray, center, normal) -> "PlaneDrag":
        c = np.asarray(center, np.float64)
        n = np.asarray(normal, np.float64)
        n = n / np.linalg.norm(n)
        t = ray_plane(ray, c, n)
        hit = ray.at(t) if t is not None else c
        return cls(c.copy(), n, c - hit)

    def move(self, ray: Ray) -> np.ndarray | None:
        """The new centre for the mouse ray, or None when the ray misses the plane."""
        t = ray_plane(ray, self.point, self.normal)
        if t is None:
            return None
        return ray.at(t) + self.offset


@dataclass
class SphereDrag:
    """Dragging a handle over a sphere about ``center`` (a directional light's handle: its
    direction is the handle's, seen from the centre). The handle stays on the side of the
    sphere it was grabbed on (facing the camera, or behind the centre); a ray that misses the
    sphere puts it on the silhouette, at the sphere's point nearest the ray."""

    center: np.ndarray
    radius: float
    near_side: bool

    @classmethod
    def start(cls, ray: Ray, center, radius: float, handle) -> "SphereDrag":
        c = np.asarray(center, np.float64)
        facing = float(np.dot(np.asarray(handle, np.float64) - c, ray.direction)) <= 0.0
        return cls(c.copy(), float(radius), facing)

    def point(self, ray: Ray) -> np.ndarray:
        """Where the handle goes for the mouse ray: on the sphere."""
        hits = ray_sphere_hits(ray, self.center, self.radius)
        if hits is not None and hits[1] >= 0:
            t = hits[0] if self.near_side and hits[0] >= 0 else hits[1]
            return ray.at(t)
        p = closest_on_ray(ray, self.center) - self.center
        n = np.linalg.norm(p)
        if n < 1e-12:
            return self.center + self.radius * -ray.direction
        return self.center + p / n * self.radius

    def move(self, ray: Ray) -> np.ndarray:
        """The unit direction from the centre to the handle for the mouse ray."""
        d = self.point(ray) - self.center
        return d / np.linalg.norm(d)


KEY_DIRECTIONS = {
    "w": (0.0, 0.0, 1.0), "s": (0.0, 0.0, -1.0),    # forward, back (camera, horizontal)
    "d": (1.0, 0.0, 0.0), "a": (-1.0, 0.0, 0.0),    # right, left
    "e": (0.0, 1.0, 0.0), "q": (0.0, -1.0, 0.0),    # up, down (world)
}


def keyboard_offset(keys, camera: Camera, distance: float) -> np.ndarray:
    """The displacement for the held ``keys`` (letters of KEY_DIRECTIONS), ``distance`` metres long."""
    v = np.zeros(3)
    for k in keys:
        v += np.asarray(KEY_DIRECTIONS.get(str(k).lower(), (0.0, 0.0, 0.0)))
    if not np.any(v):
        return np.zeros(3)
    f = np.asarray(camera.forward, np.float64).copy()
    f[1] = 0.0
    f = f / np.linalg.norm(f) if np.linalg.norm(f) > 1e-9 else np.array([0.0, 0.0, -1.0])
    right = np.cross(f, [0.0, 1.0, 0.0])
    d = right * v[0] + np.array([0.0, 1.0, 0.0]) * v[1] + f * v[2]
    return d / np.linalg.norm(d) * float(distance)
