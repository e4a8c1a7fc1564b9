"""DBK-buffer (Hunz 2016, §5.3): depth-bounded per-pixel lists over an opaque layer.

1. depth pre-pass: the nearest hair depth z0 of every pixel (atomicMin of the float bits in an
   r32ui image; depth-tested against the head);
2. fill: fragments within ``shift`` behind z0 go to the linked lists (the A-buffer's pool,
   overflow counted and grown the same way); a fragment behind the layer marks its pixel;
3. behind: the hair behind the layer, with depth test and writes into the HDR target (the
   in-layer fragments discarded): opaque as in the thesis (``oit_dbk_behind="opaque"``), or
   by default blended with its alpha like the "none" path (unsorted, but a lone strand behind
   a thin layer keeps its transparency);
4. resolve: each list sorted (``oit_k`` nearest, 0: all) and blended over that opaque layer.

Beyond the thesis, ``oit_auto_shift`` chooses the shift every frame. The resolve measures the
mean fragment alpha, and from it k = ceil(log(oit_threshold) / log(1 - alpha)) (2..64: the
layer should hold the k nearest fragments, behind which less than the threshold of light
passes); and in each pixel the depth behind z0 of its k-th nearest fragment (where the layer
held fewer than k but the pixel has hair behind it and is dense, at least k/2 in the layer:
extrapolated, fragments taken as evenly spread in depth; pixels with fewer than k fragments in
all, or sparse in front of a gap, do not count) into a 64-bin histogram (atomics, 4 x the
shift wide). The next frame's shift is the ``oit_shift_quantile`` of it (at most 4x up or
down a frame; the first guess of k uses half the strand opacity). A
frame with no history (the first) calibrates with up to 3 measuring passes (pre-pass, fill,
measure) before it draws. The depth is linear view depth (m) along the camera axis.
"""
from __future__ import annotations

import math

import numpy as np

from .a_buffer import COUNTER_WORDS, NODE_BYTES, PPLLMethod
from ..bindings import IMG_OIT_FRONT
from ..passes.base import set_uniform
from .base import END

HIST_FIRST, HIST_BINS = 8, 64
CALIBRATION_PASSES = 3


class AutoShift:
    """The automatic depth shift (``oit_auto_shift``), shared by the hardware DBK-buffer and
    the compute one (compute.ComputeDBKBuffer): the state, the first frame's calibration and
    the update from a frame's counters (words 2..4 and the histogram from word 8, which both
    resolves fill alike). The host class provides ``settings``, ``collect()``,
    ``measure_layer(frame)`` (one measuring pass: layer, measure-only resolve), ``overflow``
    and ``_pending``."""

    def init_shift(self) -> None:
        self.shift = float(self.settings.oit_depth_shift)
        self.hist_max = 4.0 * self.shift
        self.history = False
        self.layer_fragments = 0.0      # mean in-layer fragments per hair pixel (last frame)
        self.hair_pixels = 0
        self.shifts: list[float] = []
        self._measure_hist_max = self.hist_max
        self.mean_alpha = None          # measured mean fragment alpha (last frame)
        self.k_target = self.target_k(min(0.95, float(self.settings.oit_opacity) * 0.5))

    @property
    def auto(self) -> bool:
        return bool(self.settings.oit_auto_shift)

    def calibrate(self, frame) -> None:
        """First frame: measure the layer and adapt the shift before drawing."""
        for _ in range(CALIBRATION_PASSES):
            self.measure_layer(frame)
            before = self.shift
            self._pending = True
            self.collect()
            if abs(self.shift - before) <= 0.1 * before and not self.overflow:
                break

    def target_k(self, alpha: float) -> int:
        """Fragments a layer must hold for (1 - alpha)^k < oit_threshold (2..64)."""
        alpha = min(max(float(alpha), 1e-3), 0.999)
        k = math.ceil(math.log(float(self.settings.oit_threshold)) / math.log(1.0 - alpha))
        return int(min(max(k, 2), 64))

    def update_shift(self, c: np.ndarray) -> None:
        """A frame's counters: c[2] layer fragments, c[3] hair pixels, c[4] alpha sum x 64,
        c[HIST_FIRST:] the histogram of the depth each pixel needs."""
        self.hair_pixels = int(c[3])
        self.layer_fragments = float(c[2]) / max(1, int(c[3]))
        if int(c[2]) > 0:
            self.mean_alpha = float(c[4]) / 64.0 / float(c[2])
        hist = c[HIST_FIRST:HIST_FIRST + HIST_BINS].astype(np.int64)
        if not self.auto:
            return
        if self.mean_alpha is not None:
            self.k_target = self.target_k(self.mean_alpha)
        if hist.sum() == 0:
            self.history = True
            return
        self.history = True
        q = float(self.settings.oit_shift_quantile)
        cum = np.cumsum(hist)
        b = int(np.searchsorted(cum, q * cum[-1]))
        width = self._measure_hist_max / HIST_BINS
        new = (b + 1) * width          # the bin's far edge
        floor = 2.0 * float(self.settings.width)
        new = float(min(max(new, 0.25 * self.shift, floor), 4.0 * self.shift))
        self.shift = new
        self.hist_max = 4.0 * new
        self.shifts.append(new)

    def shift_stats(self) -> dict:
        return {"oit_shift_m": self.shift, "oit_auto_shift": self.auto,
                "oit_layer_fragments_per_pixel": self.layer_fragments, "oit_hair_pixels": self.hair_pixels,
                "oit_threshold": float(self.settings.oit_threshold), "oit_k_target": self.k_target,
                "oit_mean_alpha": self.mean_alpha}


class DBKBuffer(AutoShift, PPLLMethod):
    name = "dbk_buffer"
    method_id = 5

    def __init__(self, renderer):
        super().__init__(renderer)
        self.init_shift()

    def resize(self) -> None:
        super().resize()
        self.texture("front", 1, "u4")

    # ------------------------------------------------------------------ frame
    def begin(self, frame) -> None:
        if not self.auto:
            self.shift = float(self.settings.oit_depth_shift)
        self.collect()
        if self.auto and not self.history:
            self.calibrate(frame)
        self._clear()

    def _clear(self) -> None:
        self.clear_image(self.get("heads"), END)
        self.clear_image(self.get("front"), END)
        self.clear_buffer(self.get("counter"), 0)
        self.barrier()

    def _bind_front(self, read_only: bool = False) -> None:
        self.get("front").bind_to_image(IMG_OIT_FRONT, read=True, write=not read_only)

    def _layer(self, frame) -> None:
        """Pre-pass and in-layer fill."""
        fbo = self.fbo("fill", [])
        for stage in (1, 2):
            prog = self.hair_program(stage)
            self.setup_hair(prog, frame)
            self.bind_lists(prog)
            self._bind_front()
            set_uniform(prog, "u_oit_shift", float(self.shift))
            self.fill_state(fbo)
            self.draw(prog, frame)
            self.end_fill(fbo)
            self.barrier()

    def fill(self, frame) -> None:
        self._layer(frame)
        # the hair behind the layer, opaque, into the HDR target (depth test and writes on)
        opaque = self.settings.oit_dbk_behind == "opaque"
        prog = self.hair_program(3, OIT_DBK_BEHIND_OPAQUE=int(opaque))
        self.setup_hair(prog, frame)
        self._bind_front(read_only=True)
        set_uniform(prog, "u_oit_shift", float(self.shift))
        hdr = self.r.hdr_fbo()
        ctx = self.ctx
        self.fill_state(hdr, depth_write=True, blend=None if opaque else (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA))
        self.draw(prog, frame)
        self.end_fill(hdr)
        self._pending = True

    def _resolve_program(self, measure_only: bool = False):
        prog = self.resolve_program("resolve_ppll.frag", OIT_MEASURE_ONLY=int(measure_only))
        self.bind_lists(prog, read_only=True)
        self._bind_front(read_only=True)
        set_uniform(prog, "u_oit_shift", float(self.shift))
        set_uniform(prog, "u_oit_k_target", int(self.k_target))
        self._measure_hist_max = self.hist_max
        set_uniform(prog, "u_oit_hist_max", float(self.hist_max))
        return prog

    def resolve(self, frame) -> None:
        self.composite(self._resolve_program())

    def measure_layer(self, frame) -> None:
        """One calibration pass (AutoShift.calibrate): layer and measure-only resolve."""
        self._clear()
        self._layer(frame)
        self.composite(self._resolve_program(measure_only=True))
        self.barrier()

    def after_frame(self, c: np.ndarray) -> None:
        super().after_frame(c)      # the pool (PPLLMethod)
        self.update_shift(c)

    def stats(self) -> dict:
        out = super().stats()
        out.update(self.shift_stats())
        return out

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        """Heads + front depth (4 + 4 B a pixel) + the node pool."""
        w, h = size or settings.render_size
        per = float(fragments_per_pixel if fragments_per_pixel is not None else settings.oit_nodes_per_pixel)
        return int(8 * w * h + NODE_BYTES * math.ceil(per * w * h) + 4 * COUNTER_WORDS)
