"""The GPU side of a data set: one SampleRenderer per GPU process renders samples into raw
arrays (the images and maps, the camera, the strands); encoding them is left to CPU workers.

    sr = SampleRenderer(spec)                 # a headless context, one Renderer kept for all
    raw = sr.render(sample_params(spec, 3))   # dict of arrays and JSON-able values
    a = sr.start(sample_params(spec, 4))      # or one frame ahead: issue 4, then 5, ...
    b = sr.start(sample_params(spec, 5))
    raw4 = sr.finish(a)                       # ... and read 4 while the GPU renders 5
"""
from __future__ import annotations

import math
import time
from collections import OrderedDict
from functools import lru_cache
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .sampling import SampleParams
from .spec import DatasetSpec

CV_FROM_GL = np.diag([1.0, -1.0, -1.0, 1.0])   # OpenCV camera axes (x right, y down, z forward)
ROWS_ONE_THREAD = 16384   # (rows x 4) @ (4 x 4): OpenBLAS's one-thread size (SMP_THRESHOLD_MIN 65536 x 4)


def to_camera(h: np.ndarray, cv: np.ndarray) -> np.ndarray:
    """(P, 3) float32: (P, 4) float64 homogeneous points ``h`` through the 4x4 ``cv``, the
    values of ``(h @ cv.T)[:, :3].astype(np.float32)``. The product goes in row blocks that
    OpenBLAS runs on one thread (m * n * k <= 262,144): on the whole array it starts a thread
    per core, which measured 26 ms for 50k points beside busy processes (1 ms alone); each
    row is the same dot product either way."""
    out = np.empty((len(h), 3), np.float32)
    for i in range(0, len(h), ROWS_ONE_THREAD):
        out[i:i + ROWS_ONE_THREAD] = (h[i:i + ROWS_ONE_THREAD] @ cv.T)[:, :3]
    return out


def groom_key(p: SampleParams) -> tuple:
    return (p.groom, p.groom_file, p.groom_seed if p.groom_file is None else 0, p.head)


@lru_cache(maxsize=8)
def load_head(base_dir: str, name: str):
    """A head by spec name: "none", "default" (the procedural bust) or a mesh file (cached)."""
    if name == "none":
        return None
    if name == "default":
        from ..grooming.scene import default_head

        return default_head()
    from ..io import load_mesh

    return load_mesh(Path(base_dir) / name)


def make_groom(spec: DatasetSpec, p: SampleParams):
    """Sample ``p``'s groom: grown (procedural styles grow on its head, on the default bust
    for "none") or loaded (and scaled). Deterministic: the same in every process."""
    src = spec.grooms[p.groom]
    if src.style is not None:
        from ..grooming import grow

        head = load_head(spec.base_dir, p.head if p.head != "none" else "default")
        return grow(head, src.strands, src.style, src.points, p.groom_seed, **src.style_options)
    from ..io import load

    g = load(Path(spec.base_dir) / p.groom_file)
    return g.scaled(src.scale) if src.scale != 1.0 else g


class SampleRenderer:
    def __init__(self, spec: DatasetSpec, ctx=None, cache: int = 4):
        from ..gpu.context import get_context, renderer_name
        from ..render.aux_maps import AuxMaps
        from ..render.readback import FrameReadback
        from ..render.renderer import Renderer

        self.spec = spec
        self.ctx = ctx if ctx is not None else get_context()
        self.settings = spec.render_settings()
        self.renderer = Renderer(self.settings, ctx=self.ctx, profile=False)
        self.aux = AuxMaps(self.renderer)
        self.renderer_string = renderer_name(self.ctx)
        self._grooms: OrderedDict = OrderedDict()
        self._pending: dict = {}   # groom key -> a CPU worker's future (prefetch)
        self._cache = int(cache)
        self._current = None   # (groom key, head) on the renderer now
        self._frame_of = (None,)   # (id, centroid, lo, hi, groom) of the last groom framed
        self._homogeneous: tuple = (None, None)   # (groom, its points as (P, 4) float64 with w = 1)
        # the maps but "segment" (no file holds it; AuxMaps.read has it after a render)
        self.readback = FrameReadback(self.renderer, self.aux, hdr="hdr" in spec.outputs or "exr" in spec.outputs,
                                      segment=False)
        # seconds: prepare (the sample's scene on the CPU), issue (the CPU issuing the frame and
        # its read-back copies), gpu_wait (waiting for the GPU to pass the frame's fence),
        # readback (mapping the copies into arrays), camera_strands (camera.json, the strands)
        self.timings = dict.fromkeys(("prepare", "issue", "gpu_wait", "readback", "camera_strands"), 0.0)

    # ------------------------------------------------------------------ scene pieces
    def head(self, name: str):
        return load_head(self.spec.base_dir, name)

    def groom(self, p: SampleParams):
        key = groom_key(p)
        if key in self._grooms:
            self._grooms.move_to_end(key)
            return key, self._grooms[key]
        pending = self._pending.pop(key, None)
        g = pending.result() if pending is not None else make_groom(self.spec, p)
        self._grooms[key] = g
        while len(self._grooms) > self._cache:
            self._grooms.popitem(last=False)
        return key, g

    def prefetch(self, upcoming, submit, ahead: int = 2) -> None:
        """Have ``submit(make_groom, spec, params) -> future`` (CPU workers) grow or load the
        next ``ahead`` hairstyles of ``upcoming`` (SampleParams in render order) while this
        process renders: a new groom then costs no GPU time."""
        for p in upcoming:
            key = groom_key(p)
            if key in self._grooms or key in self._pending:
                continue
            if len(self._pending) >= ahead:
                break
            self._pending[key] = submit(make_groom, self.spec, p)

    def simulate(self, groom, head, p: SampleParams):
        """(posed groom, head transform) after p.sim_seconds of motion and wind."""
        from ..sim import MeshCollider, SimSettings, Simulator, WindSettings, head_motion

        s = self.spec.simulation
        colliders = [MeshCollider(head, resolution=48, margin=0.002, friction=0.3)] if head is not None else []
        sim = Simulator(groom, colliders, SimSettings(wind=WindSettings(velocity=tuple(p.wind), gust=0.3)), self.ctx)
        lo, hi = head.bbox() if head is not None else (groom.roots.min(axis=0), groom.roots.max(axis=0))
        pivot = ((lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2)
        motion = head_motion.preset(p.motion, pivot=pivot)
        frames = max(1, int(round(p.sim_seconds * s.fps)))
        m = np.eye(4)
        for f in range(frames):
            m = motion((f + 1) / s.fps)
            sim.set_head_transform(m)
            sim.advance(1.0 / s.fps)
        posed = sim.groom.replace(points=sim.positions().astype(np.float32))
        sim.release()
        return posed, m

    # ------------------------------------------------------------------ one sample
    def camera(self, groom, p: SampleParams):
        from ..render.camera import Camera

        key = id(groom)
        if self._frame_of[0] != key:   # the hair's centroid and bounds, once per groom
            pts = np.asarray(groom.points)
            self._frame_of = (key, pts.mean(axis=0, dtype=np.float64), pts.min(axis=0), pts.max(axis=0), groom)
        _, mean, lo, hi, _ = self._frame_of
        # the hair's centroid: near the scalp, where the hair is densest (a bbox centre drops
        # to the shoulders for long hair)
        centre = mean + np.asarray(p.jitter)
        az, el = math.radians(p.azimuth), math.radians(p.elevation)
        d = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
        eye = centre + d * p.distance
        radius = 0.5 * float(np.linalg.norm(np.asarray(hi, float) - lo)) + 0.3   # hair and head
        near = max(0.005, p.distance - radius)
        return Camera(tuple(eye), tuple(centre), (0.0, 1.0, 0.0), p.fov_y, near=near, far=p.distance + radius)

    def render(self, p: SampleParams) -> dict:
        """Sample ``p``'s raw arrays (start and finish in one: the CPU waits for the GPU)."""
        return self.finish(self.start(p))

    def start(self, p: SampleParams) -> dict:
        """Set up sample ``p``'s scene, issue its frame and queue its read-back; returns the
        ticket ``finish`` takes. Start the next sample before finishing this one and the GPU
        renders it while the CPU reads this one (at most ``readback.slots`` started at once)."""
        from ..render.lights import Light
        from ..render.renderer import ShadingAdapter

        t0 = time.perf_counter()
        r = self.renderer
        key, groom = self.groom(p)
        head = self.head(p.head)
        transform = np.eye(4)
        if p.sim_seconds > 0:
            groom, transform = self.simulate(groom, head, p)
            key = None
        settings = self.settings.replace(hair_color=None, ambient=p.ambient,
                                         shading_options={**self.settings.shading_options, "melanin": p.melanin})
        if r.settings != settings:
            r.settings = settings
            r.shading = ShadingAdapter(settings.shading, settings.hair_color, settings.shading_options)
        if key is None or self._current != key:
            r.set_strands(groom)
            self._current = key
        if r.head is not head:
            r.set_head(head)
        r.set_head_transform(transform)
        cam = self.camera(groom, p)
        lights = [Light("directional", tuple(d), tuple(c), float(i)) for d, c, i, _ in p.lights]
        t1 = time.perf_counter()
        r.render(cam, lights)
        slot = self.readback.start()
        t2 = time.perf_counter()
        self.timings["prepare"] += t1 - t0
        self.timings["issue"] += t2 - t1
        return {"p": p, "slot": slot, "groom": groom, "camera": cam, "transform": transform,
                "id_counts": (r.rendered_strands, r.strands.num_guides)}

    def finish(self, ticket: dict) -> dict:
        """The raw arrays of a started sample: waits for its frame, reads it back (see the
        module's docstring for the keys)."""
        t0 = time.perf_counter()
        maps, waited = self.readback.read(ticket["slot"])
        t1 = time.perf_counter()
        p, cam, groom, transform = ticket["p"], ticket["camera"], ticket["groom"], ticket["transform"]
        raw = {"key": p.key, "index": p.index, **maps, "id_counts": ticket["id_counts"]}
        w, h = self.settings.size
        view = cam.view()
        cv = CV_FROM_GL @ view
        f = (h / 2.0) / math.tan(math.radians(cam.fov_y) / 2.0)
        raw["camera"] = {
            "width": w, "height": h,
            "K": [[f, 0.0, w / 2.0], [0.0, f, h / 2.0], [0.0, 0.0, 1.0]],
            "world_to_camera": cv.tolist(),
            "world_to_camera_gl": view.tolist(),
            "eye": list(cam.eye), "target": list(cam.target), "fov_y": cam.fov_y, "near": cam.near, "far": cam.far,
            "conventions": ("K and world_to_camera: OpenCV (x right, y down, z forward; pixel (u, v) has its "
                            "centre at (u + 0.5, v + 0.5)); world_to_camera_gl: OpenGL view (-z forward); metres"),
            "lights": [{"direction": list(d), "color": list(c), "intensity": i, "temperature": t}
                       for d, c, i, t in p.lights],
            "ambient": p.ambient,
            "head_transform": transform.tolist(),
            "params": asdict(p),
            "strands_per_guide": int(self.settings.strands_per_guide),
            "renderer": self.renderer_string,
        }
        if "strands" in self.spec.outputs:
            raw["strands"] = {"points": self._camera_points(groom, cv), "counts": groom.counts.astype(np.int32)}
        self.timings["gpu_wait"] += waited
        self.timings["readback"] += t1 - t0 - waited
        self.timings["camera_strands"] += time.perf_counter() - t1
        return raw

    def cancel(self) -> None:
        """Drop the samples started and not finished (a shard stopped by an error)."""
        self.readback.cancel()

    def _camera_points(self, groom, cv: np.ndarray) -> np.ndarray:
        """The groom's points in camera space (its homogeneous points kept while it is the last
        groom seen)."""
        if self._homogeneous[0] is not groom:
            self._homogeneous = (groom, np.c_[groom.points.astype(np.float64), np.ones(groom.num_points)])
        return to_camera(self._homogeneous[1], cv)

    def release(self) -> None:
        self.readback.release()
        self.aux.release()
        self.renderer.release()
