"""Guide strands on the GPU for the renderer: a Groom uploaded, or a simulator's own buffer.

    strands = StrandBuffers.from_groom(ctx, groom)            # uploads (resampled if ragged)
    strands = StrandBuffers.from_simulator(sim)               # binds sim.state.positions: no copy

Layout (the simulator's): every guide has ``N`` points, point ``k`` of guide ``g`` is
``positions[g*N + k]``, a vec4 (xyz metres, w unused here). ``frames`` (vec4 per point) holds a
parallel-transported unit normal per point, rebuilt on the GPU each frame by
``update_frames`` (compute shader ``passes/guide_frames.comp``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import GroomError, UsageError
from ..gpu.buffers import as_device, check_allocation
from ..gpu.glsl import ProgramMemo, compute_shader
from ..gpu.uniforms import write_uniform
from ..io.units import check_groom_span
from .bindings import B_FRAMES, B_POSITIONS

HERE = Path(__file__).resolve().parent
PASSES = HERE / "passes"
DEFAULT_POINTS = 16
MAX_POINTS = 256


def uniform_groom(groom, points_per_strand: int | None = None):
    """The groom with every strand at the same point count (resampled when needed)."""
    n = groom.uniform_count
    if points_per_strand is not None:
        n_want = int(points_per_strand)
        if not 2 <= n_want <= MAX_POINTS:
            raise UsageError(f"points per strand must be in 2..{MAX_POINTS}, got {n_want}")
        return groom if n == n_want else groom.resampled(n_want)
    if n is None or n > MAX_POINTS:
        return groom.resampled(min(MAX_POINTS, max(DEFAULT_POINTS, int(np.median(groom.counts)))))
    return groom


class StrandBuffers:
    """Guide positions (vec4 per point) and frames on the GPU, plus what the renderer needs."""

    def __init__(self, ctx, positions, num_guides: int, points_per_strand: int, *,
                 bbox=None, owns_positions: bool = False, source=None):
        if points_per_strand < 2:
            raise GroomError("strands need at least 2 points to be rendered")
        self.ctx = ctx
        self.positions = positions
        self.num_guides = int(num_guides)
        self.points_per_strand = int(points_per_strand)
        self.owns_positions = owns_positions
        self.source = source
        check_allocation(ctx, self.num_points * 16, f"the frames of {self.num_guides:,} guides x "
                         f"{self.points_per_strand} points", reduce="Use fewer guides or points per guide")
        self.frames = as_device(ctx.buffer(reserve=self.num_points * 16))
        self._bbox = None if bbox is None else (np.asarray(bbox[0], float), np.asarray(bbox[1], float))
        self.guide_triangles = None   # (S, 3) int32 guides blended by multi-strand interpolation
        self._programs = ProgramMemo()   # update_frames' kernel (a simulator's frames: every frame)
        self.update_frames()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_groom(cls, ctx, groom, points_per_strand: int | None = None) -> "StrandBuffers":
        g = uniform_groom(groom, points_per_strand)
        check_groom_span(*g.bbox())
        pts = g.as_padded().astype(np.float32)
        S, N = pts.shape[:2]
        # positions and frames: both before either is made
        check_allocation(ctx, S * N * 32, f"the positions and frames of {S:,} guides x {N} points",
                         reduce="Use fewer guides or points per guide")
        data = np.zeros((S * N, 4), np.float32)
        data[:, :3] = pts.reshape(-1, 3)
        data[:, 3] = 1.0
        buf = as_device(ctx.buffer(data.tobytes()))
        return cls(ctx, buf, S, N, bbox=g.bbox(), owns_positions=True, source=g)

    @classmethod
    def from_simulator(cls, sim) -> "StrandBuffers":
        """Read the simulator's position SSBO directly (no copy); frames follow every ``update_frames``."""
        st = sim.state
        lo, hi = sim.groom.bbox()
        return cls(sim.ctx, st.positions, st.num_strands, st.points_per_strand,
                   bbox=(lo, hi), owns_positions=False, source=sim)

    # ------------------------------------------------------------------ data
    @property
    def num_points(self) -> int:
        return self.num_guides * self.points_per_strand

    @property
    def num_segments(self) -> int:
        return self.num_guides * (self.points_per_strand - 1)

    def read_positions(self) -> np.ndarray:
        """(S, N, 3) float32 read back (for tests, framing and debugging)."""
        raw = np.frombuffer(self.positions.read(size=self.num_points * 16), np.float32)
        return raw.reshape(self.num_guides, self.points_per_strand, 4)[:, :, :3].copy()

    def read_frames(self) -> np.ndarray:
        raw = np.frombuffer(self.frames.read(), np.float32)
        return raw.reshape(self.num_guides, self.points_per_strand, 4)[:, :, :3].copy()

    def bbox(self, refresh: bool = False) -> tuple[np.ndarray, np.ndarray]:
        if self._bbox is None or refresh:
            p = self.read_positions().reshape(-1, 3)
            self._bbox = (p.min(axis=0).astype(float), p.max(axis=0).astype(float))
        return self._bbox

    def set_guide_triangles(self, triangles) -> None:
        """(S, 3) guide indices each rendered clump blends (multi-strand interpolation)."""
        t = np.asarray(triangles, dtype=np.int32).reshape(-1, 3)
        if len(t) != self.num_guides or t.min() < 0 or t.max() >= self.num_guides:
            raise UsageError(f"guide triangles must be ({self.num_guides}, 3) indices of guides")
        self.guide_triangles = t

    def mean_length(self) -> float:
        """The guides' mean polyline length (m): from the groom uploaded, else read back once (a
        simulator's guides keep their rest length: constraints hold it)."""
        if getattr(self, "_mean_length", None) is None:
            from .coverage_lod import mean_strand_length

            src = self.source
            groom = getattr(src, "groom", src)
            if groom is not None and hasattr(groom, "as_padded") and getattr(groom, "uniform_count", None):
                self._mean_length = mean_strand_length(groom.as_padded())
            else:
                self._mean_length = mean_strand_length(self.read_positions())
        return self._mean_length

    def bind(self) -> None:
        self.positions.bind_to_storage_buffer(B_POSITIONS)
        self.frames.bind_to_storage_buffer(B_FRAMES)

    def update_frames(self) -> None:
        """Rebuild the transported frames from the current positions (a compute dispatch)."""
        cs = self._programs.get("frames", (), lambda: compute_shader(self.ctx, PASSES / "guide_frames.comp"))
        write_uniform(cs["u_n"], self.points_per_strand)
        write_uniform(cs["u_num_guides"], self.num_guides)
        self.bind()
        cs.run((self.num_guides + 63) // 64)
        self.ctx.memory_barrier()

    def release(self) -> None:
        self.frames.release()
        if self.owns_positions:
            self.positions.release()
