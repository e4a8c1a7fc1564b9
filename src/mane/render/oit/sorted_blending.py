"""Sorted blending (Hunz §5, "Blending"; his sort ran on the CPU): every frame a compute
shader keys each guide segment (patch) by the view depth of its midpoint, a bitonic sort
(shared-memory blocks of 512, global steps above) orders them far to near, and an index
buffer of the sorted patches draws the hair back to front with premultiplied "over" blending
(depth test against the head, no depth writes). Segments, not whole strands, are sorted; the
strands a patch expands into (clump, 64 isolines) share its key, so crossing strands can
still blend in the wrong order (the thesis' Fig. 39c). Multi / hybrid interpolation draws
groups of strands per patch: there the patches are drawn unsorted (a warning says so).
Memory: 8 B a padded key + 16 B of indices a patch (no per-pixel storage)."""
from __future__ import annotations

import math

from ...gpu.glsl import compute_shader
from ..bindings import B_SORT_INDICES, B_SORT_KEYS
from ..passes.base import set_uniform
from .base import HERE, OitMethod, _groups

BLOCK = 512


class SortedBlending(OitMethod):
    name = "sorted_blending"
    method_id = 1

    def __init__(self, renderer):
        super().__init__(renderer)
        self._vao = None
        self._vao_key = None
        self.patches = 0
        self.dispatches = 0

    @property
    def k(self) -> int:
        return 1

    def _buffers(self):
        st = self.r.strands
        patches = st.num_guides * (st.points_per_strand - 1)
        padded = max(BLOCK, 1 << max(0, math.ceil(math.log2(max(patches, 1)))))
        keys = self.buffer("keys", 8 * padded)
        idx = self.buffer("indices", 16 * patches)
        self.patches, self.padded = patches, padded
        return keys, idx

    def sort(self, frame) -> None:
        ctx, st = self.ctx, self.r.strands
        keys, idx = self._buffers()
        n = self.padded
        st.bind()
        keys.bind_to_storage_buffer(B_SORT_KEYS)
        cs = compute_shader(ctx, HERE / "sort_keys.comp")
        set_uniform(cs, "u_n", st.points_per_strand)
        set_uniform(cs, "u_patches", self.patches)
        set_uniform(cs, "u_padded", n)
        set_uniform(cs, "u_eye", tuple(float(x) for x in frame.view.eye))
        set_uniform(cs, "u_view_dir", tuple(float(x) for x in frame.view.forward))
        cs.run(*_groups(n), 1)
        ctx.memory_barrier()
        local = compute_shader(ctx, HERE / "bitonic.comp", defines={"LOCAL": 1})
        glob = compute_shader(ctx, HERE / "bitonic.comp", defines={"LOCAL": 0})
        blocks = n // BLOCK
        set_uniform(local, "u_k", 0)
        local.run(blocks, 1, 1)
        ctx.memory_barrier()
        d = 1
        k = 2 * BLOCK
        while k <= n:
            j = k // 2
            while j >= BLOCK:
                set_uniform(glob, "u_k", k)
                set_uniform(glob, "u_j", j)
                glob.run(*_groups(n // 2), 1)
                ctx.memory_barrier()
                d += 1
                j //= 2
            set_uniform(local, "u_k", k)
            local.run(blocks, 1, 1)
            ctx.memory_barrier()
            d += 1
            k *= 2
        idx.bind_to_storage_buffer(B_SORT_INDICES)
        ix = compute_shader(ctx, HERE / "sort_indices.comp")
        set_uniform(ix, "u_patches", self.patches)
        ix.run(*_groups(self.patches), 1)
        ctx.memory_barrier()
        self.dispatches = d + 2

    def fill(self, frame) -> None:
        ctx, r = self.ctx, self.r
        sorted_ok = r.settings.interpolation_mode == "single"
        if sorted_ok:
            with self.section("sort"):
                self.sort(frame)
        elif not any("unsorted" in w for w in self.warnings):
            self.warnings.append("sorted blending: multi / hybrid interpolation draws its patches unsorted")
        prog = self.hair_program(1)
        self.setup_hair(prog, frame)
        vao = None
        if sorted_ok:
            key = (id(prog), id(self.get("indices")))
            if self._vao_key != key:
                if self._vao is not None:
                    self._vao.release()
                self._vao = ctx.vertex_array(prog, [], index_buffer=self.get("indices"), index_element_size=4)
                self._vao_key = key
            vao = self._vao
        hdr = r.hdr_fbo()
        self.fill_state(hdr, blend=(ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA))
        self.draw(prog, frame, vao=vao)
        self.end_fill(hdr)

    def resolve(self, frame) -> None:
        pass    # blended straight into the HDR target

    def stats(self) -> dict:
        out = super().stats()
        out.update({"oit_sorted_patches": self.patches, "oit_sort_dispatches": self.dispatches})
        return out

    def release(self) -> None:
        if self._vao is not None:
            self._vao.release()
            self._vao = None
            self._vao_key = None
        super().release()

    @classmethod
    def estimate_bytes(cls, settings, size=None, fragments_per_pixel=None, patches: int = 0) -> int:
        padded = max(BLOCK, 1 << max(0, math.ceil(math.log2(max(patches, 1))))) if patches else 0
        return int(8 * padded + 16 * patches)
