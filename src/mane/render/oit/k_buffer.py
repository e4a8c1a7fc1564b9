"""K-buffer: the ``oit_k`` nearest fragments of every pixel (Bavoil et al. 2007; Hunz's
K+-buffer, §5.2), with the fragments pushed out blended order-independently behind them
(their alpha-weighted mean colour with their total transmittance).

Three insertion forms (``RenderSettings.oit_kbuffer``; "auto" picks the first available of
atomic64, interlock, atomic32):

``atomic32`` (any GL 4.3, the one llvmpipe runs)
    two hair draws. 1: each fragment's 32-bit key (24-bit depth in the hair's depth range,
    8-bit id) is kept by atomicMin bubbling through the K slots (each atomicMin keeps the
    smaller value, the larger moves on: lock-free, the slots end sorted). 2: every fragment is
    shaded; the one whose key is in a slot stores its half-float colour there, the others go
    to the tail. Memory: K x (4 + 8) + 10 B a pixel.
``atomic64`` (GL_ARB_gpu_shader_int64 + GL_NV_shader_atomic_int64)
    one draw: the key is depth24 | colour40 (10-bit r, g, b as x/(1+x), 10-bit alpha) and
    bubbles with 64-bit atomicMin; the value out of the last slot is the tail's. K x 8 + 10 B.
``interlock`` (GL_ARB_fragment_shader_interlock)
    one draw: an insertion into sorted depth / half-colour slots inside
    beginInvocationInterlockARB / endInvocationInterlockARB. K x 12 + 10 B.
"""
from __future__ import annotations

from ...errors import GLFeatureError
from ..bindings import B_OIT_COLORS, B_OIT_KEYS, TEX_OIT_RESOLVE
from ..passes.base import set_uniform
from .base import END, OitMethod

MODES = {"atomic32": 0, "atomic64": 1, "interlock": 2}
FLT_MAX_BITS = 0x7F7FFFFF
TAIL_BYTES = 8 + 2      # RGBA16F sums + R16F alpha sum


def pick_mode(ctx, wanted: str = "auto") -> str:
    from ...gpu.capabilities import get_capabilities

    caps = get_capabilities(ctx)
    have64 = caps.available("kbuffer_int64")
    have_il = caps.has_extension("GL_ARB_fragment_shader_interlock")
    if wanted == "auto":
        return "atomic64" if have64 else "interlock" if have_il else "atomic32"
    if wanted == "atomic64" and not have64:
        raise GLFeatureError("the 64-bit atomic K-buffer needs GL_ARB_gpu_shader_int64 and "
                             "GL_NV_shader_atomic_int64 (use oit_kbuffer='atomic32')")
    if wanted == "interlock" and not have_il:
        raise GLFeatureError("the interlock K-buffer needs GL_ARB_fragment_shader_interlock "
                             "(use oit_kbuffer='atomic32')")
    return wanted


def slot_bytes(mode: str) -> int:
    return {"atomic32": 12, "atomic64": 8, "interlock": 12}[mode]


class KBuffer(OitMethod):
    name = "k_buffer"
    method_id = 4

    def __init__(self, renderer):
        super().__init__(renderer)
        self.mode = pick_mode(self.ctx, self.settings.oit_kbuffer)

    def resize(self) -> None:
        K, P = self.k, self.pixels
        if self.mode == "atomic64":
            self.buffer("keys", 8 * K * P)
        else:
            self.buffer("keys", 4 * K * P)
            self.buffer("colors", 8 * K * P)
        self.texture("tail", 4, "f2")
        self.texture("tail_alpha", 1, "f2")

    def begin(self, frame) -> None:
        K, P = self.k, self.pixels
        if self.mode == "atomic64":
            self.clear_buffer(self.get("keys"), END, 2 * K * P)
        elif self.mode == "interlock":
            self.clear_buffer(self.get("keys"), FLT_MAX_BITS, K * P)
        else:
            self.clear_buffer(self.get("keys"), END, K * P)
        self.clear_color("tail", [self.get("tail"), self.get("tail_alpha")], (0.0, 0.0, 0.0, 1.0))
        self.barrier()

    def _bind(self):
        self.get("keys").bind_to_storage_buffer(B_OIT_KEYS)
        if self.get("colors") is not None:
            self.get("colors").bind_to_storage_buffer(B_OIT_COLORS)

    def fill(self, frame) -> None:
        ctx = self.ctx
        mode = MODES[self.mode]
        tail_blend = (ctx.ONE, ctx.ONE, ctx.ZERO, ctx.ONE_MINUS_SRC_ALPHA)
        self._bind()
        if self.mode == "atomic32":
            prog = self.hair_program(1, OIT_KBUF_MODE=mode)
            self.setup_hair(prog, frame)
            fbo = self.fbo("keys", [])
            self.fill_state(fbo)
            self.draw(prog, frame)
            self.end_fill(fbo)
            self.barrier()
            stage2 = 2
        else:
            stage2 = 1
        prog = self.hair_program(stage2, glsl450=self.mode != "atomic32", OIT_KBUF_MODE=mode)
        self.setup_hair(prog, frame)
        self._bind()
        fbo = self.fbo("tail", [self.get("tail"), self.get("tail_alpha")])
        self.fill_state(fbo, blend=tail_blend)
        self.draw(prog, frame)
        self.end_fill(fbo)

    def resolve(self, frame) -> None:
        prog = self.resolve_program("resolve_k_buffer.frag", OIT_KBUF_MODE=MODES[self.mode])
        self._bind()
        self.get("tail").use(TEX_OIT_RESOLVE)
        self.get("tail_alpha").use(TEX_OIT_RESOLVE + 1)
        set_uniform(prog, "u_oit_tail", TEX_OIT_RESOLVE)
        set_uniform(prog, "u_oit_tail_alpha", TEX_OIT_RESOLVE + 1)
        set_uniform(prog, "u_oit_size", self.size)
        self.composite(prog)

    def stats(self) -> dict:
        out = super().stats()
        out["oit_kbuffer"] = self.mode
        return out

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None, mode: str = "atomic32") -> int:
        w, h = size or settings.render_size
        return int(w * h * (int(settings.oit_k) * slot_bytes(mode) + TAIL_BYTES))
