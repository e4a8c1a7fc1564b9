"""A pinhole camera: look-at view, perspective projection, automatic framing and turntables.

Matrices are NumPy float64 4x4, row-major maths (``clip = P @ V @ world``); upload them to GLSL
with ``mat_bytes`` (column-major float32).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UsageError


def normalize(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if not n > 0:
        raise UsageError(f"cannot normalise the zero vector {v.tolist()}")
    return v / n


def _unit3(x: float, y: float, z: float) -> tuple[float, float, float]:
    n = math.sqrt(x * x + y * y + z * z)
    if not n > 0:
        raise UsageError(f"cannot normalise the zero vector {[x, y, z]}")
    return x / n, y / n, z / n


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """World -> view (camera looks down -Z, Y up). Three-vectors in plain floats: a moving
    camera makes a view every frame, and NumPy's small-array calls (cross, norm) cost it more
    than the maths (docs/performance.md, "A moving camera's issue")."""
    ex, ey, ez = (float(v) for v in eye)
    tx, ty, tz = (float(v) for v in target)
    fx, fy, fz = _unit3(tx - ex, ty - ey, tz - ez)
    ux, uy, uz = (float(v) for v in up)
    nx, ny, nz = _unit3(ux, uy, uz)
    if abs(fx * nx + fy * ny + fz * nz) > 0.999:
        ux, uy, uz = (0.0, 0.0, 1.0) if abs(fz) < 0.9 else (1.0, 0.0, 0.0)
    sx, sy, sz = _unit3(fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux)
    vx, vy, vz = sy * fz - sz * fy, sz * fx - sx * fz, sx * fy - sy * fx
    return np.array([[sx, sy, sz, -(sx * ex + sy * ey + sz * ez)],
                     [vx, vy, vz, -(vx * ex + vy * ey + vz * ez)],
                     [-fx, -fy, -fz, fx * ex + fy * ey + fz * ez],
                     [0.0, 0.0, 0.0, 1.0]])


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def orthographic(half_w: float, half_h: float, near: float, far: float) -> np.ndarray:
    m = np.eye(4)
    m[0, 0], m[1, 1] = 1.0 / half_w, 1.0 / half_h
    m[2, 2] = -2.0 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m


def mat_bytes(m) -> bytes:
    """A NumPy 4x4 (row-major maths) as GLSL's column-major float32 bytes."""
    return np.asarray(m, dtype=np.float32).T.copy().tobytes()


@dataclass(frozen=True)
class Camera:
    """eye and target in metres, fov_y in degrees; near/far in metres (None: from the scene)."""

    eye: tuple[float, float, float] = (0.0, 0.0, 1.0)
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_y: float = 30.0
    near: float = 0.01
    far: float = 100.0

    def __post_init__(self) -> None:
        for name in ("eye", "target", "up"):   # lists and NumPy arrays as tuples: cameras compare and hash
            value = getattr(self, name)
            if value.__class__ is not tuple:
                try:
                    value = tuple(float(v) for v in np.asarray(value, dtype=float).reshape(-1))
                except (TypeError, ValueError):
                    raise UsageError(f"the camera's {name} must be three numbers, got {value!r}") from None
                object.__setattr__(self, name, value)
        values = [*self.eye, *self.target, *self.up, self.fov_y, self.near, self.far]
        if len(self.eye) != 3 or len(self.target) != 3 or not all(math.isfinite(float(v)) for v in values):
            raise UsageError(f"a camera needs finite numbers (eye {self.eye}, target {self.target}, "
                             f"fov {self.fov_y}, near {self.near}, far {self.far})")
        if not 0.0 < float(self.fov_y) < 180.0:
            raise UsageError(f"the camera's field of view must be in (0, 180) degrees, got {self.fov_y}")
        if not 0.0 < float(self.near) < float(self.far):
            raise UsageError(f"the camera needs 0 < near < far, got near {self.near}, far {self.far}")
        if np.allclose(np.asarray(self.eye, float), np.asarray(self.target, float), rtol=0, atol=0):
            raise UsageError(f"the camera's eye and target are the same point {self.eye}")

    def view(self) -> np.ndarray:
        return look_at(self.eye, self.target, self.up)

    def projection(self, aspect: float) -> np.ndarray:
        return perspective(self.fov_y, aspect, self.near, self.far)

    def view_projection(self, aspect: float) -> np.ndarray:
        return self.projection(aspect) @ self.view()

    @property
    def forward(self) -> np.ndarray:
        return np.array(_unit3(*(float(t) - float(e) for t, e in zip(self.target, self.eye))))

    def replace(self, **kw) -> "Camera":
        return replace(self, **kw)

    @classmethod
    def framing(cls, lo, hi, *, azimuth: float = 25.0, elevation: float = 12.0, fov_y: float = 30.0,
                aspect: float = 4 / 3, margin: float = 1.08, distance_scale: float = 1.0,
                points=None) -> "Camera":
        """A camera that sees the box [lo, hi] whole, from ``azimuth`` degrees about +Y (0 looks
        at the face, +Z toward -Z) and ``elevation`` degrees above the horizon. With ``points``
        ((N, 3), inside the box) it fits those points instead of the box's corners: a tighter
        frame, centred on the points' projection."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        for name, v in (("azimuth", azimuth), ("elevation", elevation), ("distance scale", distance_scale)):
            if not math.isfinite(float(v)):
                raise UsageError(f"the camera's {name} must be finite, got {v}")
        if not float(distance_scale) > 0:
            raise UsageError(f"the camera's distance scale must be > 0, got {distance_scale}")
        if not 0.0 < float(fov_y) < 180.0:
            raise UsageError(f"the camera's field of view must be in (0, 180) degrees, got {fov_y}")
        center = 0.5 * (lo + hi)
        az, el = math.radians(azimuth), math.radians(elevation)
        direction = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
        # fit the box's corners (or the points) in both the vertical and horizontal field of view
        view = look_at(center + direction, center)
        if points is not None and len(points):
            corners = np.asarray(points, float).reshape(-1, 3)
            rot = view[:3, :3]
            loc = (rot @ (corners - center).T).T
            # centre the frame on the points as seen from the side they are viewed from
            mid = 0.5 * (loc.min(axis=0) + loc.max(axis=0))
            center = center + rot.T @ np.array([mid[0], mid[1], 0.0])
            view = look_at(center + direction, center)
        else:
            corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        local = (view[:3, :3] @ (corners - center).T).T  # camera at distance 0 looking at center
        ty = math.tan(math.radians(fov_y) / 2.0)
        tx = ty * aspect
        # distance d such that |x| <= (d - z_local) * tx for every corner (z_local toward the camera)
        d = max(np.max(np.abs(local[:, 0]) * margin / tx + local[:, 2]),
                np.max(np.abs(local[:, 1]) * margin / ty + local[:, 2]), 1e-3)
        d *= float(distance_scale)
        radius = 0.5 * float(np.linalg.norm(hi - lo))
        eye = center + direction * d
        return cls(tuple(eye), tuple(center), (0.0, 1.0, 0.0), fov_y,
                   near=max(1e-3, d - radius * 1.5) * 0.5, far=d + radius * 2.0 + 1.0)

    def orbited(self, degrees: float) -> "Camera":
        """This camera turned ``degrees`` about the vertical axis through its target (turntable)."""
        a = math.radians(degrees)
        c, s = math.cos(a), math.sin(a)
        t = np.asarray(self.target, float)
        e = np.asarray(self.eye, float) - t
        e = np.array([c * e[0] + s * e[2], e[1], -s * e[0] + c * e[2]])
        return self.replace(eye=tuple(t + e))


def parse_camera(text: str, lo, hi, aspect: float, points=None) -> Camera:
    """--camera: "AZIMUTH,ELEVATION[,DISTANCE_SCALE[,FOV]]" (degrees) framing the scene (its
    ``points`` when given, else the box's corners), or "eye=x,y,z;target=x,y,z[;fov=deg]"."""
    text = (text or "").strip()
    try:
        if "=" in text:
            kv = dict(part.split("=", 1) for part in text.split(";") if part.strip())
            eye = tuple(float(v) for v in kv["eye"].split(","))
            center = 0.5 * (np.asarray(lo, float) + np.asarray(hi, float))
            target = tuple(float(v) for v in kv["target"].split(",")) if "target" in kv else tuple(center)
            fov = float(kv.get("fov", 30.0))
            radius = 0.5 * float(np.linalg.norm(np.asarray(hi, float) - lo))
            dist = float(np.linalg.norm(np.asarray(eye) - np.asarray(target)))
            if len(eye) != 3 or len(target) != 3:
                raise ValueError("eye and target need 3 numbers")
            return Camera(eye, target, fov_y=fov, near=max(1e-3, (dist - 2 * radius) * 0.5),
                          far=dist + 4 * radius + 1.0)
        vals = [float(v) for v in text.split(",")] if text else []
        if len(vals) > 4:
            raise ValueError("too many numbers")
        keys = ("azimuth", "elevation", "distance_scale", "fov_y")
        return Camera.framing(lo, hi, aspect=aspect, points=points, **dict(zip(keys, vals)))
    except (ValueError, KeyError) as exc:
        raise UsageError(f"bad --camera {text!r} ({exc}); use AZ,EL[,DIST_SCALE[,FOV]] or "
                         "eye=x,y,z;target=x,y,z[;fov=deg]") from None
