"""ShortCut (AMD TressFX 3.1): bounded memory, no lists. Pass 1: the 3 nearest depths per
pixel (32-bit atomicMin bubbling; TressFX's InterlockedMin) and the transmittance
prod(1 - alpha) of every fragment (multiplicative blending into an R16F target). Pass 2 (here a
comparison in pass 3 instead of TressFX's early-z depth write): the fragments no farther than
the 3rd depth are shaded and summed (premultiplied colour and alpha, additive blending).
Resolve: colour = sum(c) / sum(alpha) x (1 - prod(1 - alpha)).
Memory: 3 x 4 B depths + 8 B RGBA16F sums + 2 B R16F transmittance = 22 B a pixel."""
from __future__ import annotations

from ..bindings import B_OIT_KEYS, TEX_OIT_RESOLVE
from ..passes.base import set_uniform
from .base import END, OitMethod

SHORTCUT_K = 3
BYTES_PER_PIXEL = 4 * SHORTCUT_K + 8 + 2


class ShortCut(OitMethod):
    name = "shortcut"
    method_id = 6

    @property
    def k(self) -> int:
        return SHORTCUT_K

    def resize(self) -> None:
        self.buffer("depths", 4 * SHORTCUT_K * self.pixels)
        self.texture("transmittance", 1, "f2")
        self.texture("accum", 4, "f2")

    def begin(self, frame) -> None:
        self.clear_buffer(self.get("depths"), END, SHORTCUT_K * self.pixels)
        self.clear_color("transmittance", [self.get("transmittance")], (1.0, 1.0, 1.0, 1.0))
        self.clear_color("accum", [self.get("accum")], (0.0, 0.0, 0.0, 0.0))
        self.barrier()

    def fill(self, frame) -> None:
        ctx = self.ctx
        self.get("depths").bind_to_storage_buffer(B_OIT_KEYS)
        prog = self.hair_program(1)
        self.setup_hair(prog, frame)
        fbo = self.fbo("transmittance", [self.get("transmittance")])
        self.fill_state(fbo, blend=(ctx.ZERO, ctx.ONE_MINUS_SRC_COLOR))
        self.draw(prog, frame)
        self.end_fill(fbo)
        self.barrier()
        prog = self.hair_program(2)
        self.setup_hair(prog, frame)
        self.get("depths").bind_to_storage_buffer(B_OIT_KEYS)
        fbo = self.fbo("accum", [self.get("accum")])
        self.fill_state(fbo, blend=(ctx.ONE, ctx.ONE))
        self.draw(prog, frame)
        self.end_fill(fbo)

    def resolve(self, frame) -> None:
        prog = self.resolve_program("resolve_shortcut.frag")
        self.get("transmittance").use(TEX_OIT_RESOLVE)
        self.get("accum").use(TEX_OIT_RESOLVE + 1)
        set_uniform(prog, "u_oit_transmittance", TEX_OIT_RESOLVE)
        set_uniform(prog, "u_oit_accum", TEX_OIT_RESOLVE + 1)
        self.composite(prog)

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        return int(w * h * BYTES_PER_PIXEL)
