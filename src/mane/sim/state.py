"""The simulator's dynamic state: GPU buffers plus the few numbers that go with them.

Layout (fixed, shared with the grid passes and the renderer): every strand has the same
``N <= 64`` particles; particle ``i = strand * N + k``, root ``k = 0``. All buffers are
std430 arrays of float32 ``vec4`` (one per particle unless said):

=================  =========  ==========================================================
buffer             binding    contents
=================  =========  ==========================================================
positions          0          xyz metres (world), w inverse mass (0 = pinned)
prev_positions     1          positions at the start of the step (last valid, see guard)
velocities         2          xyz m/s, w 0
rest_positions     3          bind pose in the head's frame (after haircut), w inverse mass
rest_info          4          x rest length of segment k-1 -> k (after haircut), y rest arc
                              length root -> k, z rest angle (rad) between segments k-2 -> k-1
                              and k-1 -> k, w base length
corrections        5          DFTL correction d_k (xyz), for the velocity update
shape_refs         6          segment k-1 -> k in the bind frame of segment k-2 (local shape)
root_frames        7          3 vec4 per strand: columns of the root's bind frame (head frame)
colliders          8          ``colliders.py`` layout, rewritten every step
guard              9          uint[4]: recoveries, last bad strand + 1, 0, 0
=================  =========  ==========================================================

A ``SimState`` can be copied (``snapshot``/``restore`` on the simulator) and two states
can be stepped side by side by one simulator.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import GPUMemoryError, GroomError, UsageError
from ..gpu.buffers import DeviceBuffer, as_device, check_allocation
from ..phases import phase
from . import bindings

MAX_POINTS_PER_STRAND = 64
PARTICLE_BUFFERS = ("positions", "prev_positions", "velocities", "rest_positions", "rest_info",
                    "corrections", "shape_refs")
# buffer -> binding (the sim's table, bindings.py)
BINDINGS = {name: getattr(bindings, f"B_{name.upper()}") for name in PARTICLE_BUFFERS + ("root_frames", "colliders", "guard")}
COLLIDER_BYTES = 176
GUARD_BYTES = 16


def estimate_bytes(num_strands: int, points_per_strand: int, num_colliders: int = 0) -> dict:
    """name -> bytes of every buffer a state of this size allocates."""
    P = int(num_strands) * int(points_per_strand)
    sizes = {name: P * 16 for name in PARTICLE_BUFFERS}
    sizes["root_frames"] = int(num_strands) * 48
    sizes["colliders"] = max(1, num_colliders) * COLLIDER_BYTES
    sizes["guard"] = GUARD_BYTES
    return sizes


def _buffer_limit(ctx) -> int:
    """The largest SSBO the context binds, bytes."""
    value = ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE")
    try:
        return int(value)
    except (TypeError, ValueError):
        return 2**27  # the GL 4.3 minimum is 2**24; every desktop driver gives >= 2**27


def check_fits(ctx, num_strands: int, points_per_strand: int, num_colliders: int = 0) -> int:
    """Raise GPUMemoryError unless a state of this size fits; return its total bytes."""
    sizes = estimate_bytes(num_strands, points_per_strand, num_colliders)
    total = sum(sizes.values())
    check_allocation(ctx, total, f"the simulation state of {num_strands} strands x "
                                 f"{points_per_strand} points", ssbo=False)
    limit = _buffer_limit(ctx)
    largest = max(sizes, key=sizes.get)
    if sizes[largest] > limit:
        raise GPUMemoryError(
            f"the simulation needs a {sizes[largest] / 2**20:.1f} MiB '{largest}' buffer "
            f"({num_strands} strands x {points_per_strand} points, {total / 2**20:.1f} MiB in all) "
            f"but this OpenGL binds at most {limit / 2**20:.1f} MiB per storage buffer; "
            "simulate fewer strands (guides) or fewer points per strand")
    return total


# ---------------------------------------------------------------------- rest data
def _frame_from_direction(t: np.ndarray) -> np.ndarray:
    """(S,3,3) rotation whose columns are x = t, y, z (deterministic choice of y)."""
    S = len(t)
    helper = np.tile(np.array([0.0, 0.0, 1.0]), (S, 1))
    near = np.abs(t[:, 2]) > 0.9
    helper[near] = (1.0, 0.0, 0.0)
    y = np.cross(helper, t)
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    z = np.cross(t, y)
    return np.stack([t, y, z], axis=2)


def haircut(rest: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """(S,N,3): the rest strands cut at ``scale`` of their arc length (tips collapse on the cut).
    Uncut (every scale >= 1): ``rest`` itself, not a copy."""
    if np.all(scale >= 1.0):
        return rest
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    arc = np.concatenate([np.zeros((len(rest), 1)), np.cumsum(seg, axis=1)], axis=1)
    cut = arc[:, -1] * scale
    a = np.minimum(arc, cut[:, None])  # (S,N) wanted arc of each particle
    N = rest.shape[1]
    j = (arc[:, None, :] <= a[:, :, None]).sum(axis=2) - 1  # segment start index
    j = np.clip(j, 0, N - 2)
    S_idx = np.arange(len(rest))[:, None]
    a0, a1 = arc[S_idx, j], arc[S_idx, j + 1]
    span = np.where(a1 - a0 > 0, a1 - a0, 1.0)
    w = np.clip((a - a0) / span, 0.0, 1.0)[..., None]
    return rest[S_idx, j] * (1 - w) + rest[S_idx, j + 1] * w


def carried_refs(D: np.ndarray, seg: np.ndarray, R0: np.ndarray) -> np.ndarray:
    """(3,M,S) float64: F_k^T d_k for segments D (3,M,S) (component, segment, strand) of lengths
    seg (M,S), the bind frame carried root to tip: F_0 = R0 (S,3,3); F_{k+1} = F_k times the
    smallest rotation taking e_x to the unit F_k^T d_k (diag(-1, -1, 1) when nearly opposite),
    unchanged past an empty segment (|d_k| <= 1e-12). All strands at once for each k, a frame
    held as (column, component, strand)."""
    _, M, S = D.shape
    F = np.ascontiguousarray(R0.transpose(2, 1, 0))       # F[j, i]: component i of column j
    out = np.empty((3, M, S))
    ok = seg > 1e-12
    safe = np.where(ok, seg, 1.0)
    R = np.empty((3, 3, S))
    G, tmp = np.empty((3, 3, S)), np.empty((3, 3, S))
    u, t = np.empty((3, S)), np.empty(S)
    flip = np.diag([-1.0, -1.0, 1.0])[:, :, None]
    for k in range(M):
        ref = out[:, k]
        np.multiply(F[:, 0], D[0, k], out=ref)
        ref += F[:, 1] * D[1, k]
        ref += F[:, 2] * D[2, k]                          # F^T d
        if k == M - 1:
            break
        np.divide(ref, safe[k], out=u)
        np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2], out=t)
        okk = ok[k]
        if okk.all():
            u /= t
        else:
            u /= np.where(okk, t, 1.0)
            u[:, ~okk] = ((1.0,), (0.0,), (0.0,))         # e_x: R = I, the frame stays
        c, u1, u2 = u
        opposite = c < -1.0 + 1e-6
        flipped = opposite.any()
        den = 1.0 + c
        if flipped:
            den[opposite] = 1.0
        # the smallest rotation taking e_x to u: c I + [e_x x u]_x + (e_x x u)(e_x x u)^T / (1 + c)
        np.multiply(u1, u2, out=t)
        t /= den
        R[0, 0], R[0, 1], R[0, 2] = c, -u1, -u2
        R[1, 0], R[1, 2], R[2, 0], R[2, 1] = u1, -t, u2, -t
        np.multiply(u2, u2, out=t)
        t /= den
        np.add(c, t, out=R[1, 1])
        np.multiply(u1, u1, out=t)
        t /= den
        np.add(c, t, out=R[2, 2])
        if flipped:
            R[:, :, opposite] = flip
        # column j of F R: sum_i F[i] R[i, j]
        np.multiply(F[0][None], R[0][:, None], out=G)
        G += np.multiply(F[1][None], R[1][:, None], out=tmp)
        G += np.multiply(F[2][None], R[2][:, None], out=tmp)
        F, G = G, F
    return out


REST_CHUNK = 4096
"""strands per block of ``rest_data`` (its temporaries stay in cache; strands are independent)."""


def rest_data(base: np.ndarray, scale: np.ndarray, inv_mass: np.ndarray) -> dict:
    """Every rest-derived buffer's contents (float32) for base strands (S,N,3) and length scales (S,)."""
    S, N, _ = base.shape
    base = np.asarray(base, dtype=np.float64)
    scale = np.broadcast_to(np.asarray(scale, dtype=np.float64), (S,))
    out = {"rest_positions": np.empty((S, N, 4), np.float32), "rest_info": np.zeros((S, N, 4), np.float32),
           "shape_refs": np.zeros((S, N, 4), np.float32), "root_frames": np.zeros((S, 3, 4), np.float32)}
    out["rest_positions"][:, :, 3] = np.asarray(inv_mass, dtype=np.float32).reshape(S, N)
    for lo in range(0, S, REST_CHUNK):
        sl = slice(lo, min(S, lo + REST_CHUNK))
        _rest_block(base[sl], scale[sl], *(arr[sl] for arr in out.values()))
    return {name: arr.reshape(-1, 4) for name, arr in out.items()}


def _rest_block(base, scale, pos, info, refs, frames) -> None:
    """``rest_data`` for a block of strands, into its float32 outputs (pos's w already set).
    Worked on component-major (3, S, N-1) segments; the frame carrying on (3, N-1, S)."""
    rest = haircut(base, scale)
    pos[:, :, :3] = rest
    D = np.diff(rest.transpose(2, 0, 1), axis=2)             # (3, S, N-1)
    seg = np.sqrt(D[0] * D[0] + D[1] * D[1] + D[2] * D[2])  # (S, N-1)
    if rest is base:
        base_seg = seg
    else:
        B = np.diff(base.transpose(2, 0, 1), axis=2)
        base_seg = np.sqrt(B[0] * B[0] + B[1] * B[1] + B[2] * B[2])
    info[:, 1:, 0] = seg
    info[:, 1:, 1] = np.cumsum(seg, axis=1)
    info[:, 1:, 3] = base_seg
    # rest bend angle between segments k-2 -> k-1 and k-1 -> k, radians (0 when one is empty)
    a, b = D[:, :, :-1], D[:, :, 1:]
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    sn = np.sqrt(cx * cx + cy * cy + cz * cz)
    angle = np.arctan2(sn, a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
    angle[(seg[:, :-1] <= 1e-12) | (seg[:, 1:] <= 1e-12)] = 0.0
    info[:, 2:, 2] = angle
    # local shape: bind frames propagated root to tip
    t0 = D[:, :, 0].T / np.maximum(seg[:, :1], 1e-30)
    t0[seg[:, 0] <= 1e-12] = (0.0, -1.0, 0.0)
    R0 = _frame_from_direction(t0)
    DT = np.ascontiguousarray(D.transpose(0, 2, 1))
    refs[:, 1:, :3] = carried_refs(DT, np.ascontiguousarray(seg.T), R0).transpose(2, 1, 0)
    frames[:, :, :3] = np.transpose(R0, (0, 2, 1))  # row c = column c of R0


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    m = np.asarray(m, dtype=np.float64)
    return np.asarray(p, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]


# ---------------------------------------------------------------------- the state
class StateBuffer(DeviceBuffer):
    """A DeviceBuffer (bind it as is) that, called, reads its vec4s back as (n, 3) float32.

    ``state.positions`` is the buffer the renderer binds; ``state.positions()`` is a copy of
    its xyz in NumPy. ``before_read`` (the velocities': ``SimState.settle``) runs first.
    """

    before_read = None

    def read(self, *args, **kwargs) -> bytearray:
        if self.before_read is not None:
            self.before_read()
        return super().read(*args, **kwargs)

    def __call__(self) -> np.ndarray:
        return np.frombuffer(self.read(), dtype=np.float32).reshape(-1, 4)[:, :3].copy()


@dataclass(eq=False)
class SimState:
    """GPU buffers of one simulated groom (see the module doc for the layout)."""

    ctx: object
    num_strands: int
    points_per_strand: int
    buffers: dict
    base_rest: np.ndarray  # (S,N,3) float64 bind pose, head frame, before haircut
    inv_mass: np.ndarray  # (P,) float32
    length_scale: np.ndarray  # (S,) float64
    head: np.ndarray = field(default_factory=lambda: np.eye(4))
    """head transform of the last step (head frame -> world), 4x4."""
    head_target: np.ndarray = field(default_factory=lambda: np.eye(4))
    """head transform wanted at the end of the next step/advance (set_head_transform)."""
    time: float = 0.0
    """simulated time, s."""
    steps: int = 0
    """(sub-)steps taken."""
    last_dt: float = 0.0
    """length of the last (sub-)step, s."""
    accumulator: float = 0.0
    """time left over by ``advance`` for the next call, s."""
    collider_worlds: list | None = None
    """world transforms of the primitive colliders at the last step (for their motion)."""
    num_colliders: int = 0
    """primitive colliders in the colliders buffer."""
    mesh_worlds: list | None = None
    """world transforms of the mesh colliders at the last step (for their motion)."""
    mesh_prev_worlds: list | None = None
    """... and at the step before."""
    pending_friction: float | None = None
    """friction factor of a grid friction gather the simulator deferred to the next step's
    integrate pass (the velocities buffer lacks it until then; see ``settle``)."""
    _run_pending: object = None

    @property
    def num_particles(self) -> int:
        return self.num_strands * self.points_per_strand

    def __getattr__(self, name):  # state.positions etc. are the buffers (StateBuffer)
        buffers = self.__dict__.get("buffers")
        if buffers is not None and name in buffers:
            return buffers[name]
        raise AttributeError(name)

    @classmethod
    def allocate(cls, ctx, rest: np.ndarray, inv_mass: np.ndarray, num_colliders: int = 0) -> "SimState":
        """Buffers for strands ``rest`` (S,N,3) in their bind pose (head frame = world at bind)."""
        rest = np.asarray(rest, dtype=np.float64)
        if rest.ndim != 3 or rest.shape[2] != 3:
            raise GroomError(f"rest strands must be (S, N, 3), got {rest.shape}")
        S, N, _ = rest.shape
        if not 2 <= N <= MAX_POINTS_PER_STRAND:
            raise GroomError(f"the simulator takes 2..{MAX_POINTS_PER_STRAND} points per strand, got {N}")
        check_fits(ctx, S, N, num_colliders)
        sizes = estimate_bytes(S, N, num_colliders)
        buffers = {name: as_device(ctx.buffer(reserve=nbytes)) for name, nbytes in sizes.items()}
        for name in PARTICLE_BUFFERS:
            buffers[name].__class__ = StateBuffer
        state = cls(ctx, S, N, buffers, rest, np.ascontiguousarray(inv_mass, dtype=np.float32),
                    np.ones(S))
        buffers["velocities"].before_read = state.settle
        state.reset(state.upload_rest())
        return state

    # ---- a deferred friction gather
    def defer_gather(self, friction: float, run) -> None:
        """Leave a gather with ``friction`` to the next integrate pass; ``run(friction)`` does
        it at once (``settle``)."""
        self.pending_friction, self._run_pending = float(friction), run

    def take_pending(self) -> float | None:
        """The deferred gather's friction factor (None when there is none), now taken."""
        friction = self.pending_friction
        self.pending_friction = self._run_pending = None
        return friction

    def settle(self) -> None:
        """Run a deferred gather now, so that the velocities buffer holds the step's result."""
        run = self._run_pending
        friction = self.take_pending()
        if friction is not None:
            run(friction)

    def upload_rest(self) -> np.ndarray:
        """Write every rest-derived buffer; returns the rest positions written ((P, 4) float32)."""
        with phase("rest_data"):
            data = rest_data(self.base_rest, self.length_scale, self.inv_mass)
        with phase("state_upload"):
            for name, arr in data.items():
                self.buffers[name].write(arr)   # C-contiguous float32: written as it is, no bytes copy
        return data["rest_positions"]

    def reset(self, rest: np.ndarray | None = None) -> None:
        """Every particle at its rest position under the current head transform, at rest.
        ``rest``: the rest_positions buffer's contents when the caller has them (else read back,
        unless the head is where it was bound: then the buffer is copied on the GPU)."""
        self.take_pending()
        with phase("state_upload"):
            if np.array_equal(self.head, np.eye(4)):
                # exact: x @ I + 0 in float64 rounds back to x, so the positions are the rest
                # positions' bytes: copied on the GPU (no upload, no read-back)
                src = self.buffers["rest_positions"]
                for name in ("positions", "prev_positions"):
                    self.ctx.copy_buffer(self.buffers[name], src)
            else:
                if rest is None:
                    rest = self.read("rest_positions")
                pos = np.empty_like(rest)
                pos[:, :3] = transform_points(self.head, rest[:, :3])
                pos[:, 3] = rest[:, 3]
                pos = np.ascontiguousarray(pos, dtype=np.float32)
                self.buffers["positions"].write(pos)
                self.buffers["prev_positions"].write(pos)
            self.buffers["velocities"].clear()
            self.buffers["corrections"].clear()
            self.buffers["guard"].write(np.zeros(4, np.uint32).tobytes())
        self.time, self.steps, self.accumulator, self.last_dt = 0.0, 0, 0.0, 0.0
        self.collider_worlds = None
        self.mesh_worlds = self.mesh_prev_worlds = None

    # ---- read back
    def read(self, name: str) -> np.ndarray:
        """A CPU copy of one buffer ((n, 4) float32; the guard's (4,) uint32)."""
        buf = self.buffers[name]
        if name == "guard":
            return np.frombuffer(buf.read(), dtype=np.uint32).copy()
        return np.frombuffer(buf.read(), dtype=np.float32).reshape(-1, 4).copy()

    def write(self, name: str, data: np.ndarray) -> None:
        self.settle()   # the deferred gather works on what the step left
        arr = np.ascontiguousarray(data, dtype=np.uint32 if name == "guard" else np.float32)
        if arr.nbytes != self.buffers[name].size and name != "colliders":
            raise UsageError(f"{name}: {arr.nbytes} bytes for a buffer of {self.buffers[name].size}")
        self.buffers[name].write(arr.tobytes())

    @property
    def recoveries(self) -> int:
        return int(self.read("guard")[0])

    def release(self) -> None:
        self.take_pending()
        for buf in self.buffers.values():
            buf.release()
        self.buffers = {}
