"""A-buffer: per-pixel linked lists of every hair fragment (Yang et al. 2010; Hunz §5.1).

Fill (one hair draw, depth-tested against the head, no depth or colour writes):
``idx = atomicAdd(counter, 1)``; beyond the pool's capacity the fragment is counted and
dropped; else ``prev = imageAtomicExchange(heads, pixel, idx)`` and
``nodes[idx] = {rg half, ba half, depth, prev}`` (16 B a node; heads 4 B a pixel).

Overflow degrades gracefully: the dropped fragments are missing from this frame only; the
counter says how many fragments the frame offered, so the next frame's pool is grown to that
plus a quarter (bounded by ``oit_max_bytes`` and the GPU's SSBO limit); ``stats()`` reports
the overflow. A pool four times larger than the frames use for 8 frames in a row shrinks. Resolve: the ``oit_k`` nearest sorted, the rest of the list blended unsorted
behind them; ``oit_k = 0`` blends every fragment in depth order (exact).

``read_fragments()`` reads the lists back (the exact reference of mane.twins.oit).
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import GPUMemoryError
from ..bindings import B_PPLL_COUNTER, B_PPLL_NODES, IMG_OIT_HEADS
from ..passes.base import set_uniform
from .base import END, OitMethod

NODE_BYTES = 16
# counter words: fragments, longest list; DBK: layer fragments, hair pixels, alpha sum x 64,
# dense pixels; [8..72) the DBK's depth histogram
COUNTER_WORDS = 8 + 64
SHRINK_FRAMES = 8


class PPLLMethod(OitMethod):
    """The linked-list storage the A-buffer and the DBK-buffer share."""

    node_bytes = NODE_BYTES     # the compute A-buffer's nodes are 12 B

    def __init__(self, renderer):
        super().__init__(renderer)
        self.capacity = 0
        self.fragments = 0          # fragments offered in the last frame read back
        self.overflow = 0           # of those, dropped
        self.overflow_frames = 0
        self.max_list = 0
        self.grown = 0
        self._pending = False       # a frame's counter not read yet
        self._low_frames = 0
        self.shrunk = 0
        self._max_capacity = None

    # ------------------------------------------------------------------ pool
    def max_capacity(self) -> int:
        if self._max_capacity is None:
            from ...gpu.capabilities import get_capabilities

            limit = get_capabilities(self.ctx).limits.get("max_shader_storage_block_size") or (1 << 31)
            cap = int(limit) // self.node_bytes
            mb = int(self.settings.oit_max_bytes)
            if mb > 0:
                cap = min(cap, max(1, (mb - 4 * self.pixels) // self.node_bytes))
            self._max_capacity = max(1, cap)
        return self._max_capacity

    def resize(self) -> None:
        self._max_capacity = None
        self.texture("heads", 1, "u4")
        self.buffer("counter", 4 * COUNTER_WORDS)
        want = int(math.ceil(float(self.settings.oit_nodes_per_pixel) * self.pixels))
        if self.capacity == 0 or self.capacity < want:
            self.set_capacity(want)

    def set_capacity(self, nodes: int) -> None:
        nodes = int(min(max(nodes, 1024), self.max_capacity()))
        try:
            self.buffer("nodes", nodes * self.node_bytes)
        except GPUMemoryError as exc:
            if self.get("nodes") is None:
                raise
            self.warnings.append(f"node pool kept at {self.capacity} nodes: {exc}")
            return
        self.capacity = nodes

    def read_counter(self) -> np.ndarray:
        return np.frombuffer(self.get("counter").read(), np.uint32).copy()

    def collect(self) -> None:
        """Read the last frame's counters (a small read back): overflow, growth for the next frame."""
        if not self._pending:
            return
        self._pending = False
        c = self.read_counter()
        self.after_frame(c)

    def after_frame(self, c: np.ndarray) -> None:
        self.fragments = int(c[0])
        self.max_list = int(c[1])
        self.overflow = max(0, self.fragments - self.capacity)
        # a pool four times what the frames use, SHRINK_FRAMES in a row, shrinks to 1.25x
        floor = int(math.ceil(float(self.settings.oit_nodes_per_pixel) * self.pixels))
        if not self.overflow and self.capacity > max(4 * self.fragments, floor):
            self._low_frames += 1
            if self._low_frames >= SHRINK_FRAMES:
                self._low_frames = 0
                self.set_capacity(max(int(math.ceil(self.fragments * 1.25)), floor))
                self.shrunk += 1
        else:
            self._low_frames = 0
        if self.overflow:
            self.overflow_frames += 1
            want = int(math.ceil(self.fragments * 1.25))
            before = self.capacity
            self.set_capacity(want)
            if self.capacity > before:
                self.grown += 1
            if self.capacity < self.fragments:
                msg = (f"{self.name}: the node pool is capped at {self.capacity} nodes "
                       f"({self.capacity * self.node_bytes / 2**20:.0f} MiB; oit_max_bytes or the GPU's largest SSBO): "
                       f"fragments beyond it are dropped")
                if msg not in self.warnings:
                    self.warnings.append(msg)

    def begin_lists(self) -> None:
        self.collect()
        self.clear_image(self.get("heads"), END)
        self.clear_buffer(self.get("counter"), 0)
        self.barrier()

    def bind_lists(self, prog, read_only: bool = False) -> None:
        self.get("heads").bind_to_image(IMG_OIT_HEADS, read=True, write=not read_only)
        self.get("nodes").bind_to_storage_buffer(B_PPLL_NODES)
        self.get("counter").bind_to_storage_buffer(B_PPLL_COUNTER)
        try:
            set_uniform(prog, "u_oit_capacity", int(self.capacity))
        except KeyError:
            pass
        try:
            set_uniform(prog, "u_oit_max_steps", int(min(self.capacity, 1 << 20)))
        except KeyError:
            pass

    # ------------------------------------------------------------------ read back
    def read_fragments(self) -> dict:
        """Every stored fragment of the last frame: ``pixel`` (y * W + x, y from the bottom),
        ``depth`` (m), ``rgba`` (premultiplied, float32), ``node`` (pool index: the resolve's
        tie-break), plus ``size``, ``offered`` and ``capacity``."""
        self.ctx.finish()
        w, h = self.size
        heads = np.frombuffer(self.get("heads").read(), np.uint32).reshape(-1)
        c = self.read_counter()
        stored = int(min(c[0], self.capacity))
        raw = np.frombuffer(self.get("nodes").read(size=max(stored, 1) * NODE_BYTES), np.uint32).reshape(-1, 4)
        raw = raw[:stored]
        pix_of = np.full(stored, -1, np.int64)
        cur_pix = np.flatnonzero(heads != END)
        cur = heads[cur_pix].astype(np.int64)
        steps = 0
        while len(cur):
            ok = cur < stored
            cur, cur_pix = cur[ok], cur_pix[ok]
            pix_of[cur] = cur_pix
            nxt = raw[cur, 3].astype(np.int64)
            keep = nxt != END
            cur, cur_pix = nxt[keep], cur_pix[keep]
            steps += 1
            if steps > stored + 1:
                raise RuntimeError("the A-buffer's lists have a cycle")
        nodes = np.flatnonzero(pix_of >= 0)
        rgba = np.stack([_half(raw[nodes, 0] & 0xFFFF), _half(raw[nodes, 0] >> 16),
                         _half(raw[nodes, 1] & 0xFFFF), _half(raw[nodes, 1] >> 16)], axis=1)
        depth = raw[nodes, 2].view(np.float32)
        return {"pixel": pix_of[nodes], "depth": depth.astype(np.float32), "rgba": rgba.astype(np.float32),
                "node": nodes, "size": (w, h), "offered": int(c[0]), "capacity": int(self.capacity)}

    def stats(self) -> dict:
        self.collect()
        out = super().stats()
        out.update({"oit_fragments": self.fragments, "oit_overflow": self.overflow,
                    "oit_overflow_frames": self.overflow_frames, "oit_pool_nodes": self.capacity,
                    "oit_pool_grown": self.grown, "oit_pool_shrunk": self.shrunk, "oit_max_list": self.max_list,
                    "oit_fragments_per_pixel": self.fragments / max(1, self.pixels),
                    "oit_bytes_needed": 4 * self.pixels + self.node_bytes * self.fragments})
        return out


def _half(bits) -> np.ndarray:
    return np.asarray(bits, np.uint16).view(np.float16).astype(np.float32)


class ABuffer(PPLLMethod):
    name = "a_buffer"
    method_id = 3

    def begin(self, frame) -> None:
        self.begin_lists()

    def fill(self, frame) -> None:
        prog = self.hair_program(1)
        self.setup_hair(prog, frame)
        self.bind_lists(prog)
        fbo = self.fbo("fill", [])
        self.fill_state(fbo)
        self.draw(prog, frame)
        self.end_fill(fbo)
        self._pending = True

    def resolve(self, frame) -> None:
        prog = self.resolve_program("resolve_ppll.frag")
        self.bind_lists(prog, read_only=True)
        self.composite(prog)

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        per = float(fragments_per_pixel if fragments_per_pixel is not None else settings.oit_nodes_per_pixel)
        return int(4 * w * h + NODE_BYTES * math.ceil(per * w * h) + 4 * COUNTER_WORDS)
