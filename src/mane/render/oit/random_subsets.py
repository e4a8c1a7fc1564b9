"""Random subsets (Hunz §5.4): the strands fall into ``oit_k`` subsets by their hashed random
number; per pixel and subset only the nearest fragment is kept, and the resolve sorts those
<= k fragments by depth and blends them front to back (an approximation: a subset's farther
fragments are hidden). Hunz renders each subset to its own FBO (k draws, RGBA16 tangent +
D16, shaded deferred); here two hair draws for all subsets: 1, atomicMin of each fragment's
32-bit key (24-bit depth, 8-bit id) in its subset's slot; 2, the fragment whose key won stores
its shaded colour (half floats). Memory: k x (4 + 8) B a pixel."""
from __future__ import annotations

from ..bindings import B_OIT_COLORS, B_OIT_KEYS
from ..passes.base import set_uniform
from .base import END, OitMethod


class RandomSubsets(OitMethod):
    name = "random_subsets"
    method_id = 2

    def resize(self) -> None:
        self.buffer("keys", 4 * self.k * self.pixels)
        self.buffer("colors", 8 * self.k * self.pixels)

    def begin(self, frame) -> None:
        self.clear_buffer(self.get("keys"), END, self.k * self.pixels)
        self.barrier()

    def _bind(self):
        self.get("keys").bind_to_storage_buffer(B_OIT_KEYS)
        self.get("colors").bind_to_storage_buffer(B_OIT_COLORS)

    def fill(self, frame) -> None:
        fbo = self.fbo("fill", [])
        for stage in (1, 2):
            prog = self.hair_program(stage)
            self.setup_hair(prog, frame)
            self._bind()
            self.fill_state(fbo)
            self.draw(prog, frame)
            self.end_fill(fbo)
            if stage == 1:
                self.barrier()

    def resolve(self, frame) -> None:
        prog = self.resolve_program("resolve_random_subsets.frag")
        self._bind()
        set_uniform(prog, "u_oit_size", self.size)
        self.composite(prog)

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None) -> int:
        w, h = size or settings.render_size
        return int(w * h * int(settings.oit_k) * 12)
