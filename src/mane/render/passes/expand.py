"""pipeline="compute": every rendered strand's tessellated points in one buffer (TressFX's
"compute-tessellate, then vertex-pull").

A compute dispatch (strand_expand.comp, the tessellation evaluation stage's own code in
strand_eval.glsl) writes (S + 1) points per rendered strand, S = (guide points - 1) *
subdivisions, as 2 vec4: (position, width), (unit tangent, strand random). Every pass that
draws the hair (shadow map, deep opacity, opacity maps, ADSM, hair) then draws one instanced
strip per strand from it (hair_pull.vert): no tessellation or geometry stage in any pass,
and the curve work done once a frame instead of once a pass. The points depend on the
guides and the settings only (not on the view), so they are rebuilt only when the frames
are (new positions, a simulator's buffer every frame) or the strand table changes.
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu.glsl import ProgramMemo, compute_shader
from ..bindings import B_EXPANDED, B_STRAND_TABLE
from .base import HERE, Frame, Pass, pulls, set_strand_uniforms, set_uniform, set_uniforms, subdivisions  # noqa: F401  (pulls: here too)

LOCAL_SIZE = 128
MAX_GROUPS_X = 65535
EXPAND_POINTS = LOCAL_SIZE - 2   # points a work group of strand_expand.comp writes (its ends: neighbours)


class ExpandPass(Pass):
    name = "expand"
    reads = ("strands", "frames")
    writes = ("expanded",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.buffer = None
        self.points = 0        # per rendered strand
        self.strands = 0       # rendered strands
        self._key = None
        self._key_memo = None   # (what key() was made of, by identity; the key)
        self._dispatch_memo: dict = {}   # strand step -> (buffer shape, uniforms, work groups)
        self._programs = ProgramMemo()   # strand_expand.comp per (interpolation, mode, LOD)

    def enabled(self, frame: Frame) -> bool:
        r = self.renderer
        return r.strands is not None and pulls(r) and self._key != self.key()

    def run(self, frame: Frame) -> None:
        self.ensure()

    def key(self):
        """What the expanded buffer was made from (a new key: expand again). Kept while the
        objects it is made of are the same ones (the strands, their box, the settings, the
        geometry version, the camera's view and LOD eye, the instances): a frame asks 5 times."""
        r = self.renderer
        st = r.strands
        box = st.bbox() if st is not None else None
        memo = self._key_memo
        if memo is not None and memo[1] == r.geometry_version:
            m = memo[0]
            if (m[0] is st and m[1] is box and m[2] is r.settings and m[3] is r.lod_view and m[4] is r.lod_eye
                    and m[5] is r.instances):
                return memo[2]
        inputs = (st, box, r.settings, r.lod_view, r.lod_eye, r.instances)
        key = self._make_key()
        self._key_memo = (inputs, r.geometry_version, key)
        return key

    def _make_key(self):
        r = self.renderer
        return (id(r.strands), id(r.settings), r.geometry_version, *self.camera_key())

    def camera_key(self) -> tuple:
        """What of the expanded strands follows the camera: the distance LOD's eye (with
        settings.lod), the strands the coverage LOD keeps per instance and the segments' levels."""
        r = self.renderer
        eye = tuple(float(x) for x in r.lod_eye) if (r.settings.lod and r.lod_eye is not None) else None
        plan = r.lod_plan()
        N = r.strands.points_per_strand
        sub = plan.subdivisions(subdivisions(r.settings, N), N - 1)
        return (eye, plan.kept, sub, plan.levels(sub, N - 1))

    def ensure(self) -> None:
        """Expand now unless the buffer is up to date."""
        key = self.key()
        if key == self._key and self.buffer is not None:
            return
        r, ctx = self.renderer, self.ctx
        s, st = r.settings, r.strands
        N = st.points_per_strand
        plan = r.lod_plan()
        sub = plan.subdivisions(subdivisions(s, N), N - 1)   # the segment LOD: fewer where strands look short
        multi = s.interpolation_mode != "single"
        cs = self._programs.get("expand", (s.interpolation, s.interpolation_mode, bool(s.lod)), lambda: compute_shader(
            ctx, HERE / "strand_expand.comp", {"INTERPOLATION": _ids()["interp"][s.interpolation],
                                               "MULTI": _ids()["multi"][s.interpolation_mode], "LOD": int(bool(s.lod)),
                                               "EXPAND_LOCAL": LOCAL_SIZE, "EXPAND_POINTS": EXPAND_POINTS},
            include_dirs=[HERE.parent]))
        if multi:
            table = r.strand_table()
            table.buffer.bind_to_storage_buffer(B_STRAND_TABLE)
            per_instance = [int(table.count)] * len(plan.kept)
            set_strand_uniforms(r, cs, lod_eye=r.lod_eye)
            _set(cs, "u_num_render", int(table.count))
            key = self.key()   # the table may just have been built
            kept = [int(s.strands_per_guide)] * len(plan.kept)
        else:
            set_strand_uniforms(r, cs, lod_eye=r.lod_eye)
            kept = list(plan.kept)   # coverage LOD: the first k strands of every guide
            per_instance = [st.num_guides * k for k in kept]
        strands = sum(per_instance)
        points = (N - 1) * sub + 1
        nbytes = max(strands * points * 32, 32)
        if self.buffer is None or self.buffer.size < nbytes:   # grown, never shrunk: the LOD moves with the camera
            from ...gpu.buffers import as_device, check_allocation

            check_allocation(ctx, nbytes, f"the expanded strands ({strands:,} rendered strands x {points} points, "
                             f"32 bytes each)", reduce="Render fewer strands (guides, strands_per_guide / "
                             "--strands-per-guide), fewer segments (--segments) or a smaller lod_depth")
            if self.buffer is not None:
                self.buffer.release()
            self.buffer = as_device(ctx.buffer(reserve=nbytes))
        _set(cs, "u_subdivisions", sub)
        st.bind()
        self.buffer.bind_to_storage_buffer(B_EXPANDED)
        first = 0
        levels = plan.levels(sub, N - 1) if not multi else (sub,) * len(kept)
        for model, n, k, scale, level in zip(r.instance_transforms(), per_instance, kept, plan.width_scale, levels):
            if n == 0:
                continue
            _set(cs, "u_level", int(level))
            _set(cs, "u_num_strands", n)
            _set(cs, "u_kept_per_guide", max(1, k))
            _set(cs, "u_width_scale", float(scale) if not multi else 1.0)
            _set(cs, "u_first_strand", first)
            _set(cs, "u_model", np.asarray(model, dtype=np.float64))
            run_1d(cs, n * points, EXPAND_POINTS)
            first += n
        ctx.memory_barrier()
        self.points, self.strands, self._key = points, strands, key

    @property
    def segments(self) -> int:
        """Segments of the expanded strands (points - 1 a strand)."""
        return self.strands * max(self.points - 1, 0)

    def dispatch_segments(self, cs, strand_step: int = 1) -> None:
        """Run compute shader ``cs`` (local_size_x = LOCAL_SIZE) with one invocation per expanded
        segment: the buffer at B_EXPANDED, u_points_per_strand and u_num_segments set (the
        compute rasteriser's scan conversions). ``strand_step`` m > 1: the segments of every
        m-th strand only (the kernel maps its strand S to S x m: raster_segment.glsl's
        RASTER_STRAND)."""
        groups = self.bind_segments(cs, strand_step)
        if groups is not None:
            cs.run(*groups)

    def bind_segments(self, cs, strand_step: int = 1) -> tuple[int, int] | None:
        """dispatch_segments without the dispatch: the buffer bound and the uniforms set; the work
        groups (x, y) it would run (None: no segments), for an indirect dispatch's arguments."""
        self.ensure()
        self.buffer.bind_to_storage_buffer(B_EXPANDED)
        uniforms, groups = self._dispatch_plan(max(1, int(strand_step)))
        set_uniforms(cs, uniforms)
        return groups

    def _dispatch_plan(self, step: int = 1) -> tuple:
        """dispatch_segments' uniforms and work groups, kept while the expanded buffer's shape
        and the stride are the same."""
        key = (self.points, self.strands)
        memo = self._dispatch_memo.get(step)
        if memo is None or memo[0] != key:
            if len(self._dispatch_memo) >= 8:   # a moving camera's strides
                self._dispatch_memo.clear()
            segments = -(-int(self.strands) // step) * max(self.points - 1, 0)
            memo = self._dispatch_memo[step] = (key, {"u_points_per_strand": int(self.points),
                                                      "u_num_segments": segments}, groups_1d(segments))
        return memo[1], memo[2]

    def read(self) -> np.ndarray:
        """(strands, points, 8) float32: x, y, z, width, tx, ty, tz, strand random; instance by
        instance, in each the first kept strands (coverage LOD) of every guide, guide by guide."""
        self.ensure()
        data = np.frombuffer(self.buffer.read(size=self.strands * self.points * 32), np.float32)
        return data.reshape(self.strands, self.points, 8).copy()

    def draw(self, prog, lines: bool) -> None:
        """Every rendered strand: one instance of a strip through its points."""
        import moderngl

        self.ensure()
        self.buffer.bind_to_storage_buffer(B_EXPANDED)
        _set(prog, "u_points_per_strand", self.points)
        vao = self.renderer.empty_vao(prog)
        if lines:
            vao.render(moderngl.LINE_STRIP, vertices=self.points, instances=self.strands)
        else:
            vao.render(moderngl.TRIANGLE_STRIP, vertices=2 * self.points, instances=self.strands)

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
            self.buffer = None
        self._key = self._key_memo = None


def run_1d(cs, n: int, per_group: int = LOCAL_SIZE) -> None:
    """Dispatch ``cs`` (local_size_x = LOCAL_SIZE) over n items, ``per_group`` a work group, x
    then y groups (the shader flattens gl_WorkGroupID); nothing for n = 0."""
    groups = groups_1d(n, per_group)
    if groups is not None:
        cs.run(*groups)


def groups_1d(n: int, per_group: int = LOCAL_SIZE) -> tuple[int, int] | None:
    """run_1d's work groups (x, y) for n items; None for n = 0."""
    groups = math.ceil(int(n) / per_group)
    if groups <= 0:
        return None
    gx = min(groups, MAX_GROUPS_X)
    return gx, math.ceil(groups / gx)


def _ids():
    from .base import INTERPOLATION_IDS, MULTI_IDS

    return {"interp": INTERPOLATION_IDS, "multi": MULTI_IDS}


_set = set_uniform
