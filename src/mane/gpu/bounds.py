"""A grid's box around particles (the simulator's friction and FLIP grids, the renderer's density
grid), found on the GPU every step with no CPU readback.

    bounds = GridBounds(ctx, relative_margin=0.1, cubic=True)
    bounds.update(positions, num_particles)     # 2 dispatches: reduce, finalize
    friction.apply(positions, velocities, n, 0.1, bounds=bounds)   # grid kernels read bounds.buffer

The reduction turns each coordinate into an order-preserving int key (the float's bits,
with the magnitude bits flipped for negative numbers), reduces a workgroup in shared
memory and then does one ``atomicMin``/``atomicMax`` per workgroup into a 64-byte SSBO.
A one-invocation kernel pads the box (``margin`` metres plus ``relative_margin`` times the
largest extent on every side), makes it cubic if asked, and resets the keys for the next
step. NaN and infinite positions are ignored. The layout is in ``shaders/grid_bounds.glsl``:

    int   keys[8]   // bytes 0..31: float_key(min xyz), -, float_key(max xyz), -
    vec4  lo        // bytes 32..47: padded box minimum (metres), w unused
    vec4  hi        // bytes 48..63: padded box maximum (metres), w unused

Grid kernels map the box to their own nodes or cells; a fixed box can be set with ``set``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UsageError
from .bindings import B_BOUNDS, B_POSITIONS
from .buffers import as_device

HERE = Path(__file__).resolve().parent
BOUNDS_BINDING = B_BOUNDS   # the binding every grid kernel reads the box from
BOUNDS_BYTES = 64
PER_INVOCATION = 8          # particles each invocation of the reduction reads
KEY_POS_INF = 0x7F800000
KEY_NEG_INF = np.int32(np.uint32(0x807FFFFF).view(np.int32))


# --------------------------------------------------------------------------- small GL helpers
def set_uniforms(prog, **values) -> None:
    """Set the uniforms that the program kept (drivers drop unused ones)."""
    for name, value in values.items():
        try:
            member = prog[name]
        except KeyError:
            continue
        member.value = value


def groups(count: int, local: int) -> int:
    return max(1, (int(count) + local - 1) // local)


def storage_barrier(ctx) -> None:
    import moderngl

    ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)


def check_particle_buffers(num_particles: int, *buffers) -> int:
    n = int(num_particles)
    if n < 0:
        raise UsageError(f"num_particles must be >= 0, got {n}")
    for b in buffers:
        if b is not None and b.size < n * 16:
            raise UsageError(f"a particle buffer holds {b.size // 16} vec4s but num_particles is {n}")
    return n


# --------------------------------------------------------------------------- GridBounds
class GridBounds:
    """A padded axis-aligned box that follows the particles, kept in a GPU buffer.

    margin: metres added on every side. relative_margin: fraction of the largest extent
    added on every side. cubic: make the box a cube around its centre (equal cell sizes on
    every axis for any resolution). min_extent: metres, the smallest side length.
    """

    def __init__(self, ctx, *, margin: float = 0.0, relative_margin: float = 0.05,
                 cubic: bool = True, min_extent: float = 1e-3):
        from .glsl import compute_shader

        if margin < 0 or relative_margin < 0 or min_extent <= 0:
            raise UsageError("GridBounds: margin and relative_margin must be >= 0 and min_extent > 0")
        self.ctx = ctx
        self.margin = float(margin)
        self.relative_margin = float(relative_margin)
        self.cubic = bool(cubic)
        self.min_extent = float(min_extent)
        self.buffer = as_device(ctx.buffer(reserve=BOUNDS_BYTES))
        self._reset_keys(lo=np.zeros(3), hi=np.full(3, self.min_extent))
        self._reduce = compute_shader(ctx, HERE / "bounds.comp",
                                      {"STAGE_REDUCE": 1, "PER_INVOCATION": PER_INVOCATION})
        self._finalize = compute_shader(ctx, HERE / "bounds.comp", {"STAGE_FINALIZE": 1})

    def _reset_keys(self, lo, hi) -> None:
        keys = np.array([KEY_POS_INF] * 4 + [KEY_NEG_INF] * 4, dtype=np.int32)
        box = np.zeros(8, np.float32)
        box[0:3] = lo
        box[4:7] = hi
        self.buffer.write(keys.tobytes() + box.tobytes())

    def update(self, positions, num_particles: int, *, reduced: bool = False) -> "GridBounds":
        """Recompute the box from the first ``num_particles`` vec4s of ``positions`` (GPU only).

        ``reduced``: another kernel has already put the positions' min/max into the buffer's
        keys (the strand solver's BOUNDS option): only the padding stage runs."""
        n = check_particle_buffers(num_particles, positions)
        positions.bind_to_storage_buffer(B_POSITIONS)
        self.buffer.bind_to_storage_buffer(BOUNDS_BINDING)
        if n and not reduced:
            set_uniforms(self._reduce, num_particles=n)
            self._reduce.run(groups(n, 256 * PER_INVOCATION))
            storage_barrier(self.ctx)
        set_uniforms(self._finalize, margin=self.margin, relative_margin=self.relative_margin,
                     min_extent=self.min_extent, cubic=int(self.cubic))
        self._finalize.run(1)
        storage_barrier(self.ctx)
        return self

    def set(self, lo, hi) -> "GridBounds":
        """Fix the box to [lo, hi] (metres) until the next ``update``."""
        lo = np.asarray(lo, np.float64).reshape(3)
        hi = np.asarray(hi, np.float64).reshape(3)
        if not np.all(hi > lo):
            raise UsageError(f"GridBounds.set: hi {hi} must exceed lo {lo} on every axis")
        self._reset_keys(lo, hi)
        return self

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) float32 (3,) each: a CPU readback, for tests and debugging."""
        data = np.frombuffer(self.buffer.read(), dtype=np.float32)
        return data[8:11].copy(), data[12:15].copy()

    def bind(self) -> None:
        self.buffer.bind_to_storage_buffer(BOUNDS_BINDING)

    def release(self) -> None:
        self.buffer.release()


def padded_box(points: np.ndarray, *, margin=0.0, relative_margin=0.05, cubic=True,
               min_extent=1e-3) -> tuple[np.ndarray, np.ndarray]:
    """NumPy twin of ``GridBounds.update`` (float32 arithmetic like the shader)."""
    p = np.asarray(points, np.float32).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p):
        lo, hi = p.min(axis=0), p.max(axis=0)
    else:
        lo = hi = np.zeros(3, np.float32)
    pad = np.float32(margin) + np.float32(relative_margin) * (hi - lo).max()
    lo, hi = lo - pad, hi + pad
    centre = np.float32(0.5) * (lo + hi)
    half = np.maximum(np.float32(0.5) * (hi - lo), np.float32(0.5 * min_extent))
    if cubic:
        half = np.full(3, half.max(), np.float32)
    widened = half > np.float32(0.5) * (hi - lo)
    return (np.where(widened, centre - half, lo).astype(np.float32),
            np.where(widened, centre + half, hi).astype(np.float32))
