"""Asynchronous read-back of frames for data sets: right after Renderer.render, ``start`` queues
GPU copies of the frame's 8-bit image, its ground-truth maps (AuxMaps) and, on request, its
linear HDR colour into one of ``slots`` staging buffers, and a fence; ``read`` waits for that
fence and maps the buffers. Between the two the next frame can be issued, so the GPU renders it
while the CPU reads and packs this one.

    rb = FrameReadback(renderer, aux, hdr=False)
    renderer.render(cam_a, lights); a = rb.start()
    renderer.render(cam_b, lights); b = rb.start()   # the GPU renders b ...
    maps, waited = rb.read(a)                        # ... while a is read
    maps["rgb"]     # what Renderer.read_image gives; the AuxMaps.read keys; "hdr": read_hdr's
                    # (segment=False: all maps but "segment", a seventh less to copy)

The bytes are those of read_image, AuxMaps.read and read_hdr (the same targets, copied on the
GPU first). A slot must be read before it is started again.
"""
from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..gpu.fence import Fence


class FrameReadback:
    def __init__(self, renderer, aux, hdr: bool = False, slots: int = 2, segment: bool = True):
        self.renderer = renderer
        self.aux = aux
        self.hdr = bool(hdr)
        self.segment = bool(segment)   # False: the maps without "segment" (a seventh less to copy)
        self.slots = int(slots)
        self._buffers: list[dict | None] = [None] * self.slots
        self._pending: list[tuple | None] = [None] * self.slots   # (fence, aux size, its bytes, image size, hdr size)
        self._next = 0

    def _slot(self, k: int, sizes: dict) -> dict:
        bufs = self._buffers[k]
        if bufs is None or any(bufs[name].size < n for name, n in sizes.items()):
            self._release_slot(k)
            bufs = self._buffers[k] = {name: self.renderer.ctx.buffer(reserve=n) for name, n in sizes.items()}
        return bufs

    def start(self) -> int:
        """Queue the copies of the last frame into the next slot; returns the slot."""
        r, k = self.renderer, self._next
        if self._pending[k] is not None:
            raise UsageError(f"read-back slot {k} is still pending: read it before starting another frame")
        w, h = r.settings.size
        aux_bytes = self.aux.nbytes(self.segment)
        sizes = {"rgb": w * h * 3, "aux": aux_bytes}
        color = None
        if self.hdr:
            color, _ = r.hdr_textures()
            sizes["hdr"] = color.size[0] * color.size[1] * 8
        bufs = self._slot(k, sizes)
        r.output_fbo().read_into(bufs["rgb"], components=3, alignment=1)   # a pixel-pack buffer: queued
        aux_size = self.aux.copy_to(bufs["aux"], self.segment)
        if color is not None:
            color.read_into(bufs["hdr"], alignment=1)
        self._pending[k] = (Fence(), aux_size, aux_bytes, (w, h), color.size if color is not None else None)
        self._next = (k + 1) % self.slots
        return k

    def read(self, k: int) -> tuple[dict, float]:
        """(the maps of the frame started in slot ``k``, seconds waited for the GPU)."""
        pending = self._pending[k]
        if pending is None:
            raise UsageError(f"read-back slot {k} has no frame started")
        fence, aux_size, aux_bytes, (w, h), hdr_size = pending
        self._pending[k] = None
        waited = fence.wait()
        bufs = self._buffers[k]
        out = {"rgb": np.frombuffer(bufs["rgb"].read(size=w * h * 3), np.uint8).reshape(h, w, 3)[::-1].copy()}
        out.update(self.aux.unpack(bufs["aux"].read(size=aux_bytes), aux_size, self.segment))
        if hdr_size is not None:
            hw, hh = hdr_size
            data = np.frombuffer(bufs["hdr"].read(size=hw * hh * 8), np.float16).reshape(hh, hw, 4)[::-1, :, :3]
            out["hdr"] = np.ascontiguousarray(data)
        return out, waited

    def _release_slot(self, k: int) -> None:
        for b in (self._buffers[k] or {}).values():
            b.release()
        self._buffers[k] = None

    def cancel(self) -> None:
        """Forget the frames started and not read (after an error mid-way)."""
        for k in range(self.slots):
            if self._pending[k] is not None:
                self._pending[k][0].release()
            self._pending[k] = None

    def release(self) -> None:
        self.cancel()
        for k in range(self.slots):
            self._release_slot(k)
