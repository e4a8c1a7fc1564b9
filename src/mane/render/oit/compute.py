"""The OIT methods drawn by the compute rasteriser (no triangles, no raster units).

Datacentre GPUs (H100/H200) keep raster and ROP units on a couple of their SMs only, so hair
drawn as triangle strips is bound by a sliver of the chip there; the A-buffer, K-buffer,
DBK-buffer and ShortCut run on compute shaders instead when the renderer would draw the opaque
hair with its compute rasteriser (``settings.rasterizer`` "compute", or "auto" on such a GPU;
``pipeline="compute"``, no distance LOD): ``make_method`` picks the classes here. Method names
and settings are the hardware path's; ``stats()`` says ``rasterizer: "compute"``.

Every pass reads the expanded strands (passes/expand.py) and scan-converts each segment with
passes/raster_segment.glsl, one sample per pixel (oit_raster.comp); a fragment is a (pixel,
segment) pair in front of the head (segments and columns behind the head's depth tile map skipped whole:
passes/depth_tiles.py), keyed by its window depth's float bits over the segment
id; its alpha is clamp(coverage x oit_opacity) and its colour the hair BSDF at the segment's
point nearest the pixel centre (compute_oit.glsl). The resolve (oit_resolve.comp, one thread a
pixel) shades the kept fragments, blends them front to back over the head and background in
the HDR image and leaves the storage empty for the next frame.

``a_buffer``
    per-pixel linked lists (head pointers, a node pool of {depth bits, segment, next} = 12 B,
    one counter; overflow counted and the pool grown or shrunk as the hardware A-buffer's);
    resolve: the ``oit_k`` nearest sorted, the rest unsorted behind them (0: all, in order).
``k_buffer``
    the ``oit_k`` nearest keys per pixel (pixel-major slots) by an atomicMin insertion cascade;
    a key pushed out of the last slot is shaded and added to the pixel's tail (fixed-point
    sums of colour, alpha and -log(1 - alpha), and a count), blended behind the slots as the
    K+-buffer's. With 64-bit atomics (GL_NV_shader_atomic_int64) one pass of 64-bit keys;
    else two: 32-bit depth keys, then each fragment claims the slot holding its depth
    (``oit_kbuffer`` "atomic32" forces this form; "interlock" has no compute form: "auto").
``dbk_buffer``
    a depth pass (atomicMin of the depth bits: the front), then the fragments within the shift
    of the front go to a K-buffer as above (``oit_k`` slots; 0: 64); the layer's fragments
    beyond the slots are blended with the colour of the farthest kept one (no shading in the
    raster passes). Of the hair behind the layer only its nearest fragment (64-bit atomicMin;
    32-bit: depth, then id in a third pass) and its total optical depth are kept: blended
    behind the layer with the nearest's colour and the opacity of all of it, or that fragment
    opaque (``oit_dbk_behind="opaque"``, Hunz). The automatic shift is the hardware
    DBK-buffer's (dbk_buffer.AutoShift): the resolve measures the same counters and histogram.
``shortcut``
    the 3 nearest keys as the K-buffer's (no tail) and every fragment's -log(1 - alpha);
    resolve: their alpha-weighted mean colour with the opacity of all.

Memory (``oit_bytes``): K-buffer K x 8 + 24 B a pixel; DBK-buffer K x 8 + 12 + 4 + 8 + 4 B
(+ 2 x 5 KiB of counters); ShortCut 3 x 8 + 4 B; A-buffer 4 B a pixel + 12 B a node (+ 288 B).

``capture = True`` on a method (tests) also records every fragment of the frame (pixel,
depth, segment, premultiplied colour) into ``captured``: the exact reference, sorted on the
CPU by src/mane/twins/oit.py.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import GLFeatureError
from ...gpu.capabilities import has_atomic64
from ...gpu.glsl import compute_shader
from ..bindings import (B_EXPANDED, B_OIT_BEHIND, B_OIT_BEHIND_OPTICAL, B_OIT_COUNTER, B_OIT_FRONT,
                        B_OIT_HEADS, B_OIT_MEASURE, B_OIT_NODES, B_OIT_RECORDS, B_OIT_SLOT_IDS, B_OIT_SLOTS,
                        B_OIT_TAIL, IMG_HDR, TEX_SCENE_DEPTH)
from ..passes.base import RENDER_DIR, Frame, bind_lighting, bounce_defines, set_uniform, set_view, shadow_defines
from ..passes import depth_tiles
from ..passes.raster_segment import raster_defines
from .a_buffer import COUNTER_WORDS, PPLLMethod
from .base import END, HERE, OitMethod
from .dbk_buffer import AutoShift

COMPUTE_METHODS = ("a_buffer", "k_buffer", "dbk_buffer", "shortcut")
CM_IDS = {"a_buffer": 1, "k_buffer": 2, "dbk_buffer": 3, "shortcut": 4, "capture": 9}
TAIL_WORDS = 6
MAX_SLOTS = 64
GROUP = 16                  # oit_resolve.comp's work group: 16 x 16 pixels (the A-buffer's: 8 x 8)
MEASURE_COPIES, MEASURE_STRIDE = 16, 80   # the DBK resolve's counter copies (words apart)
COMPUTE_NODE_BYTES = 12
RECORD_WORDS = 8


def uses_compute(renderer) -> bool:
    """Whether the renderer's OIT method runs on the compute rasteriser: a ported method, and
    the renderer draws with compute shaders (``Renderer.compute_raster``)."""
    return renderer.settings.oit in COMPUTE_METHODS and bool(
        getattr(renderer, "compute_raster", False))


def compute_class(name: str, renderer):
    """The compute class of method ``name`` when the renderer uses the compute path, else None."""
    if not uses_compute(renderer):
        return None
    return {"a_buffer": ComputeABuffer, "k_buffer": ComputeKBuffer, "dbk_buffer": ComputeDBKBuffer,
            "shortcut": ComputeShortCut}.get(name)


def depth_constants(view) -> tuple[float, float, float]:
    """(perspective, y, z) of compute_oit.glsl's oit_view_depth: window depth -> view depth (m)."""
    M = np.asarray(view.view_proj, np.float64)
    r2, r3 = M[2], M[3]
    if not view.ortho and float(r3[:3] @ r3[:3]) > 0.0:
        # clip z = a w + b (w: the view depth), so ndc = a + b / w
        a = float(r2[:3] @ r3[:3]) / float(r3[:3] @ r3[:3])
        b = float(r2[3] - a * r3[3])
        return 1.0, a, b
    fwd = np.asarray(view.forward, np.float64)
    c = float(r2[:3] @ fwd)
    return 0.0, float(r2[3] + c * (np.asarray(view.eye, np.float64) @ fwd)), c


class ComputeOit(OitMethod):
    """What the compute OIT methods share: the raster and resolve dispatches, the capture."""

    compute = True
    cm = 0
    resolve_group = GROUP

    def __init__(self, renderer):
        super().__init__(renderer)
        self.atomic64 = self._pick_keys()
        self.capture = False          # tests: record every fragment (``captured``)
        self.captured = None
        self.reset = True             # False: the resolve leaves the storage for reading back
        self._dirty = False
        self.tiles = depth_tiles.DepthTiles(self.ctx)   # the head's depth tile map (head culling)

    def _pick_keys(self) -> bool:
        wanted = self.settings.oit_kbuffer
        have = has_atomic64(self.ctx)
        if wanted == "atomic32":
            return False
        if wanted == "atomic64" and not have:
            raise GLFeatureError("the 64-bit atomic compute OIT needs GL_ARB_gpu_shader_int64 and "
                                 "GL_NV_shader_atomic_int64 (use oit_kbuffer='atomic32')")
        if wanted == "interlock":
            self.warnings.append("oit_kbuffer='interlock' has no compute form: 64-bit atomics where the GPU "
                                 "has them, else 32-bit")
        return have

    @property
    def slots_k(self) -> int:
        return max(1, self.k)

    def release(self) -> None:
        super().release()
        self.tiles.release()

    # ------------------------------------------------------------------ dispatches
    def _defines(self, shading: bool, **extra) -> dict:
        d = {"OIT_CM": self.cm, "OIT_K": self.slots_k, "OIT_ATOMIC64": int(self.atomic64),
             "MEASURE_COPIES": MEASURE_COPIES, "MEASURE_STRIDE": MEASURE_STRIDE,
             "OIT_SHADING": int(shading), "OIT_TAIL_SHADED": int(getattr(self, "tail_shaded", True))}
        if shading:
            d.update(self.r.shading.defines())
            d.update(shadow_defines(self.r.ctx, self.settings))
            d.update(bounce_defines(self.r))
        d.update(extra)
        return d

    def _common(self, cs, frame: Frame, shading: bool) -> None:
        r = self.r
        expand = r.get_pass("expand")
        expand.ensure()
        expand.buffer.bind_to_storage_buffer(B_EXPANDED)
        set_view(cs, frame.view)
        set_uniform(cs, "u_raster_size", tuple(int(v) for v in self.size))
        set_uniform(cs, "u_grid", 1)
        set_uniform(cs, "u_points_per_strand", int(expand.points))
        set_uniform(cs, "u_oit_opacity", float(self.settings.oit_opacity))
        set_uniform(cs, "u_oit_lin", depth_constants(frame.view))
        if shading:
            r.shading.bind(cs, self.ctx, r.settings)
            bind_lighting(r, cs, frame)

    def raster(self, frame: Frame, pass_id: int, shading: bool = False, cm: int | None = None, **uniforms) -> None:
        """One oit_raster.comp dispatch over every segment of the expanded strands."""
        r, ctx = self.r, self.ctx
        cull = depth_tiles.cull_defines(ctx)
        defines = self._defines(shading, OIT_PASS=int(pass_id), **raster_defines(ctx), **cull)
        if cm is not None:
            defines["OIT_CM"] = int(cm)
        cs = compute_shader(ctx, HERE / "oit_raster.comp", defines, include_dirs=[HERE, RENDER_DIR])
        self._common(cs, frame, shading)
        for k, v in uniforms.items():
            set_uniform(cs, k, v)
        _, depth = r.hdr_textures()
        if cull["RASTER_HEAD_CULL"]:
            if pass_id == 0 or self.tiles.buffer is None:   # every frame's fill starts with pass 0
                with self.section("depth_tiles"):
                    self.tiles.update(depth)
            self.tiles.bind(cs)
        depth.use(TEX_SCENE_DEPTH)
        set_uniform(cs, "u_scene_depth", TEX_SCENE_DEPTH)
        with self.section(f"raster{int(pass_id)}"):
            r.get_pass("expand").dispatch_segments(cs)
        ctx.memory_barrier()

    def resolve_pass(self, frame: Frame, measure_only: bool = False, **uniforms) -> None:
        """oit_resolve.comp over every pixel: blend into the HDR image (unless measure_only)."""
        ctx, r = self.ctx, self.r
        group = self.resolve_group
        extra = {"OIT_MEASURE_ONLY": int(measure_only), "RESOLVE_GROUP": group}
        if self.name == "dbk_buffer":
            extra["OIT_DBK_BEHIND_OPAQUE"] = int(self.settings.oit_dbk_behind == "opaque")
        cs = compute_shader(ctx, HERE / "oit_resolve.comp", self._defines(True, **extra),
                            include_dirs=[HERE, RENDER_DIR])
        self._common(cs, frame, True)
        set_uniform(cs, "u_reset", int(self.reset))
        for k, v in uniforms.items():
            set_uniform(cs, k, v)
        color, _ = r.hdr_textures()
        color.bind_to_image(IMG_HDR, read=True, write=True)
        w, h = self.size
        cs.run(math.ceil(w / group), math.ceil(h / group))
        ctx.memory_barrier()
        if not self.reset:
            self._dirty = True

    # ------------------------------------------------------------------ the frame
    def layout_key(self):
        """What the storage's layout depends on: a change reallocates it."""
        return (tuple(self.size), self.slots_k, self.atomic64, getattr(self, "tail_shaded", True))

    def run(self, frame: Frame) -> None:
        if self._size != self.layout_key():
            self.resize()
            self._size = self.layout_key()
            self._dirty = False
        if self._dirty:
            self.clear_storage()
            self._dirty = False
        with self.section("begin"):
            self.begin(frame)
        with self.section("fill"):
            self.fill(frame)
        with self.section("resolve"):
            self.resolve(frame)
        if self.capture:
            self.captured = self.capture_fragments(frame)
        self.frames += 1

    def clear_storage(self) -> None:
        """Empty the per-pixel storage (allocation; after a resolve that kept it)."""

    def begin(self, frame: Frame) -> None:
        pass

    def stats(self) -> dict:
        out = super().stats()
        out.update({"rasterizer": "compute", "oit_keys": "atomic64" if self.atomic64 else "atomic32"})
        return out

    # ------------------------------------------------------------------ the exact reference
    def capture_fragments(self, frame: Frame) -> dict:
        """Every fragment of the frame (tests): ``pixel`` (y * W + x, y from the bottom),
        ``window_z``, ``depth`` (view depth, m), ``segment``, ``rgba`` (premultiplied), ``size``."""
        ctx = self.ctx
        counter = ctx.buffer(np.zeros(4, np.uint32).tobytes())
        try:
            counter.bind_to_storage_buffer(B_OIT_COUNTER)
            self.raster(frame, 0, cm=CM_IDS["capture"])
            n = int(np.frombuffer(counter.read(), np.uint32)[0])
            records = ctx.buffer(reserve=max(n, 1) * RECORD_WORDS * 4)
            try:
                counter.bind_to_storage_buffer(B_OIT_COUNTER)
                records.bind_to_storage_buffer(B_OIT_RECORDS)
                self.raster(frame, 1, shading=True, cm=CM_IDS["capture"], u_oit_capacity=n)
                ctx.finish()
                raw = np.frombuffer(records.read(size=max(n, 1) * RECORD_WORDS * 4), np.uint32)
                raw = raw.reshape(-1, RECORD_WORDS)[:n]
            finally:
                records.release()
        finally:
            counter.release()
        f = raw[:, 3:8].copy().view(np.float32)
        return {"pixel": raw[:, 0].astype(np.int64), "window_z": raw[:, 1].copy().view(np.float32),
                "segment": raw[:, 2].astype(np.int64), "rgba": np.c_[f[:, 1:4], f[:, 0]].astype(np.float32),
                "depth": f[:, 4].copy(), "size": tuple(self.size)}


class ComputeSlots(ComputeOit):
    """K nearest keys per pixel and a tail (K-buffer, DBK-buffer; ShortCut without the tail).

    ``tail_shaded``: the fragments pushed out of the slots are shaded where they fall out and
    summed (colour, alpha, optical depth, count: 6 words a pixel); False: only their alpha,
    optical depth and count (3 words), blended with the colour of the farthest kept fragment
    (no shading in the raster passes)."""

    tail_shaded = True

    @property
    def tail_words(self) -> int:
        return TAIL_WORDS if self.tail_shaded else 3

    @property
    def tail_index(self) -> dict:
        """word of each tail sum (tests)"""
        if self.tail_shaded:
            return {"r": 0, "g": 1, "b": 2, "alpha": 3, "optical": 4, "count": 5}
        return {"alpha": 0, "optical": 1, "count": 2}

    def resize(self) -> None:
        K, P = self.slots_k, self.pixels
        if self.atomic64:
            self.buffer("slots", 8 * K * P)
        else:
            self.buffer("slots", 4 * K * P)
            self.buffer("ids", 4 * K * P)
        self.buffer("tail", 4 * self.tail_words * P)
        self.clear_storage()

    def clear_storage(self) -> None:
        self.clear_buffer(self.get("slots"), END)
        if self.get("ids") is not None:
            self.clear_buffer(self.get("ids"), END)
        self.clear_buffer(self.get("tail"), 0)
        self.ctx.memory_barrier()

    def bind_storage(self) -> None:
        self.get("slots").bind_to_storage_buffer(B_OIT_SLOTS)
        if not self.atomic64:
            self.get("ids").bind_to_storage_buffer(B_OIT_SLOT_IDS)
        self.get("tail").bind_to_storage_buffer(B_OIT_TAIL)

    def fill(self, frame: Frame) -> None:
        self.bind_storage()
        if self.atomic64:
            self.raster(frame, 0, shading=self.shades_tail)
        else:
            self.raster(frame, 0)
            self.bind_storage()
            self.raster(frame, 1, shading=self.shades_tail)

    @property
    def shades_tail(self) -> bool:
        """Whether the raster pass that fills the tail shades (the hair BSDF compiled in)."""
        return self.tail_shaded and self.cm != CM_IDS["shortcut"]

    def resolve(self, frame: Frame) -> None:
        self.bind_storage()
        self.resolve_pass(frame)

    def read_slots(self) -> dict:
        """The slots as they are now (tests; with ``reset = False`` after a frame): ``zbits``
        (P, K) uint32 depth bits (0xFFFFFFFF empty), ``segment`` (P, K) int64 (-1 empty)."""
        self.ctx.finish()
        K, P = self.slots_k, self.pixels
        if self.atomic64:
            keys = np.frombuffer(self.get("slots").read(), np.uint64).reshape(P, K)
            zbits = (keys >> np.uint64(32)).astype(np.uint32)
            seg = (keys & np.uint64(0xFFFFFFFF)).astype(np.int64)
        else:
            zbits = np.frombuffer(self.get("slots").read(), np.uint32).reshape(P, K).copy()
            seg = np.frombuffer(self.get("ids").read(), np.uint32).reshape(P, K).astype(np.int64)
        seg[zbits == END] = -1
        seg[seg == END] = -1
        return {"zbits": zbits, "segment": seg}

    def read_tail(self) -> np.ndarray:
        """(words, P) uint32: the tail sums (tests)."""
        self.ctx.finish()
        return np.frombuffer(self.get("tail").read(), np.uint32).reshape(self.tail_words, self.pixels).copy()


class ComputeKBuffer(ComputeSlots):
    name = "k_buffer"
    method_id = 4
    cm = CM_IDS["k_buffer"]

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        return int(w * h * (int(settings.oit_k) * 8 + 4 * TAIL_WORDS))

    def stats(self) -> dict:
        out = super().stats()
        out["oit_kbuffer"] = "compute/" + out["oit_keys"]
        return out


class ComputeShortCut(ComputeSlots):
    name = "shortcut"
    method_id = 6
    cm = CM_IDS["shortcut"]
    tail_shaded = False

    @property
    def tail_words(self) -> int:
        return 1

    @property
    def k(self) -> int:
        return 3

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        return int(w * h * (3 * 8 + 4))


class ComputeDBKBuffer(AutoShift, ComputeSlots):
    """The DBK-buffer on the compute rasteriser. The resolve's counters go to one of two
    buffers in turn and are read back a frame late (``begin`` reads the frame before last's),
    so that the CPU never waits for the frame it just submitted; the first frame's calibration
    reads at once. The layer's fragments beyond the slots are blended with the colour of the
    farthest kept one (``tail_shaded = False``: no shading in the raster passes)."""

    name = "dbk_buffer"
    method_id = 5
    cm = CM_IDS["dbk_buffer"]
    tail_shaded = False
    MEASURE_RING = 2

    def __init__(self, renderer):
        super().__init__(renderer)
        self.init_shift()
        self._pending = False
        self._queue: list[tuple[int, float]] = []   # (ring slot, hist_max) of resolves not read yet
        self.overflow = 0
        self.fragments = 0
        self.max_list = 0
        self.shift_drawn = None       # the shift of the last fill (stats' oit_shift_m is the next frame's)

    @property
    def slots_k(self) -> int:
        return self.k if self.k > 0 else MAX_SLOTS

    @property
    def _slot(self) -> int:
        return self.frames % self.MEASURE_RING

    def resize(self) -> None:
        P = self.pixels
        self.buffer("front", 4 * P)
        self.buffer("behind", 8 * P)
        self.buffer("behind_optical", 4 * P)
        for i in range(self.MEASURE_RING):
            self.buffer(f"measure{i}", 4 * MEASURE_COPIES * MEASURE_STRIDE, host_read=True)   # read a frame late
        self._queue.clear()
        super().resize()

    def clear_storage(self) -> None:
        super().clear_storage()
        self.clear_buffer(self.get("front"), END)
        self.clear_buffer(self.get("behind_optical"), 0)
        if self.atomic64:
            self.clear_buffer(self.get("behind"), END)
        else:
            self.clear_buffer(self.get("behind"), END, self.pixels)
            self.clear_behind_ids()
        self.ctx.memory_barrier()

    def clear_behind_ids(self) -> None:
        # the 32-bit form's second half: ids + 1, 0 = none
        P = self.pixels
        data = np.zeros(P, np.uint32).tobytes()
        self.get("behind").write(data, offset=4 * P)

    def bind_storage(self) -> None:
        super().bind_storage()
        self.get("front").bind_to_storage_buffer(B_OIT_FRONT)
        self.get("behind").bind_to_storage_buffer(B_OIT_BEHIND)
        self.get("behind_optical").bind_to_storage_buffer(B_OIT_BEHIND_OPTICAL)
        self.get(f"measure{self._slot}").bind_to_storage_buffer(B_OIT_MEASURE)

    # ------------------------------------------------------------------ frame
    def begin(self, frame: Frame) -> None:
        if not self.auto:
            self.shift = float(self.settings.oit_depth_shift)
        self.collect(lag=self.MEASURE_RING - 1)   # the frame before last: long done
        if self.auto and not self.history:
            self.collect()
            self.calibrate(frame)
        self._clear_measure()

    def _clear_measure(self) -> None:
        self.clear_buffer(self.get(f"measure{self._slot}"), 0)
        self.ctx.memory_barrier()

    def fill(self, frame: Frame) -> None:
        self.shift_drawn = float(self.shift)
        self.bind_storage()
        self.raster(frame, 0)
        if self.atomic64:
            self.raster(frame, 1, shading=self.shades_tail, u_oit_shift=float(self.shift))
        else:
            self.raster(frame, 1, u_oit_shift=float(self.shift))
            self.bind_storage()
            self.raster(frame, 2, shading=self.shades_tail, u_oit_shift=float(self.shift))

    def _resolve(self, frame: Frame, measure_only: bool) -> None:
        self.bind_storage()
        self.resolve_pass(frame, measure_only=measure_only, u_oit_shift=float(self.shift),
                          u_oit_k_target=int(self.k_target), u_oit_hist_max=float(self.hist_max))
        self._queue.append((self._slot, float(self.hist_max)))

    def resolve(self, frame: Frame) -> None:
        self._resolve(frame, measure_only=False)

    def measure_layer(self, frame: Frame) -> None:
        """One calibration pass (AutoShift.calibrate): layer and measurement, no image (the
        storage is reset); calibrate reads it at once."""
        self._clear_measure()
        self.fill(frame)
        reset = self.reset
        self.reset = True
        self._resolve(frame, measure_only=True)
        self.reset = reset

    def collect(self, lag: int = 0) -> None:
        """Read the resolves' counters, all but the ``lag`` latest, oldest first."""
        while len(self._queue) > lag:
            slot, hist_max = self._queue.pop(0)
            self._measure_hist_max = hist_max
            self.after_frame(self.read_measure(slot))

    def read_measure(self, slot: int | None = None) -> np.ndarray:
        """A resolve's counters (COUNTER_WORDS words), its copies summed (word 1: the largest)."""
        buf = self.get(f"measure{self._slot if slot is None else slot}")
        c = np.frombuffer(buf.read(), np.uint32).reshape(MEASURE_COPIES, MEASURE_STRIDE)
        out = c[:, :COUNTER_WORDS].astype(np.int64).sum(axis=0)
        out[1] = int(c[:, 1].max())
        return out

    def after_frame(self, c: np.ndarray) -> None:
        self.fragments = int(c[0])
        self.max_list = int(c[1])
        self.update_shift(c)

    def stats(self) -> dict:
        self.collect()
        out = super().stats()
        out.update(self.shift_stats())
        out.update({"oit_fragments": self.fragments, "oit_overflow": 0, "oit_max_list": self.max_list,
                    "oit_fragments_per_pixel": self.fragments / max(1, self.pixels),
                    "oit_slots": self.slots_k, "oit_shift_drawn_m": self.shift_drawn,
                    "oit_tail": "shaded" if self.tail_shaded else "farthest kept colour"})
        return out

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        k = int(settings.oit_k) or MAX_SLOTS
        tail = TAIL_WORDS if cls.tail_shaded else 3
        return int(w * h * (k * 8 + 4 * tail + 4 + 8 + 4) + cls.MEASURE_RING * 4 * MEASURE_COPIES * MEASURE_STRIDE)


class ComputeABuffer(ComputeOit, PPLLMethod):
    name = "a_buffer"
    method_id = 3
    cm = CM_IDS["a_buffer"]
    node_bytes = COMPUTE_NODE_BYTES
    resolve_group = 8       # 8 x 8 tiles: faster than 16 x 16 at 1080p (docs/performance.md)

    @property
    def slots_k(self) -> int:
        return self.k   # 0: every fragment in order

    def resize(self) -> None:
        self._max_capacity = None
        self.buffer("heads", 4 * self.pixels)
        self.buffer("counter", 4 * COUNTER_WORDS)
        want = int(math.ceil(float(self.settings.oit_nodes_per_pixel) * self.pixels))
        if self.capacity == 0 or self.capacity < want:
            self.set_capacity(want)
        self.clear_storage()

    def clear_storage(self) -> None:
        self.clear_buffer(self.get("heads"), END)
        self.ctx.memory_barrier()

    def bind_storage(self) -> None:
        self.get("heads").bind_to_storage_buffer(B_OIT_HEADS)
        self.get("nodes").bind_to_storage_buffer(B_OIT_NODES)
        self.get("counter").bind_to_storage_buffer(B_OIT_COUNTER)

    def begin(self, frame: Frame) -> None:
        self.collect()
        self.clear_buffer(self.get("counter"), 0)
        self.ctx.memory_barrier()

    def fill(self, frame: Frame) -> None:
        self.bind_storage()
        self.raster(frame, 0, u_oit_capacity=int(self.capacity))
        self._pending = True

    def resolve(self, frame: Frame) -> None:
        self.bind_storage()
        self.resolve_pass(frame, u_oit_max_steps=int(min(self.capacity, 1 << 20)))

    def read_fragments(self) -> dict:
        """Every stored fragment of the last frame (with ``reset = False``): ``pixel``,
        ``window_z``, ``segment``, ``node`` (no colours: the resolve shades; ``capture`` records
        them)."""
        self.ctx.finish()
        heads = np.frombuffer(self.get("heads").read(), np.uint32)
        stored = int(min(self.read_counter()[0], self.capacity))
        raw = np.frombuffer(self.get("nodes").read(size=max(stored, 1) * COMPUTE_NODE_BYTES), np.uint32)
        raw = raw.reshape(-1, 3)[:stored]
        pix, node, nodes = [], [], []
        for p in np.flatnonzero(heads != END):
            n, steps = int(heads[p]), 0
            while n != END and n < stored and steps <= stored:
                pix.append(p)
                nodes.append(n)
                n = int(raw[n, 2])
                steps += 1
        nodes = np.asarray(nodes, np.int64)
        return {"pixel": np.asarray(pix, np.int64), "window_z": raw[nodes, 0].view(np.float32),
                "segment": raw[nodes, 1].astype(np.int64), "node": nodes, "size": tuple(self.size)}

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        per = float(fragments_per_pixel if fragments_per_pixel is not None else settings.oit_nodes_per_pixel)
        return int(4 * w * h + COMPUTE_NODE_BYTES * math.ceil(per * w * h) + 4 * COUNTER_WORDS)


__all__ = ["COMPUTE_METHODS", "uses_compute", "compute_class", "ComputeABuffer", "ComputeKBuffer",
           "ComputeDBKBuffer", "ComputeShortCut", "depth_constants"]
