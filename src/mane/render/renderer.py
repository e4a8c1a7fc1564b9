"""The strand renderer: an ordered list of passes over one Frame, each timed by the profiler.

    r = Renderer(RenderSettings(size=(320, 240), shadows="deep_opacity"))
    r.set_strands(groom)                  # or StrandBuffers.from_simulator(sim): no copy
    r.set_head(mesh)
    r.render()                            # camera framing the scene, default lights
    img = r.read_image()                  # (H, W, 3) uint8
    r.stats()                             # {"passes": {"frames": ms, "shadow_map": ms, ...}, ...}

Passes (reads -> writes): frames (strands -> frames), shadow_map (head [+hair] -> shadow_map),
deep_opacity (strands -> dom), adsm (strands -> adsm), opacity_maps (strands -> osm),
density (strands or the simulator's grid -> density), skin_bounce (head, maps -> skin_rsm: the
skin's reflective shadow map, with settings.skin_bounce and a head), head (head, maps -> hdr),
hair (strands, maps, skin_rsm -> hdr),
resolve (hdr -> output).
"""
from __future__ import annotations

import copy
import math
import weakref

import moderngl
import numpy as np

from ..errors import GPUMemoryError, UsageError
from ..gpu import replay as gl_replay
from ..gpu.clear import clear_texture
from ..gpu.context import get_context, renderer_name
from ..gpu.glsl import ProgramMemo
from ..gpu.lifetime import GpuOwner
from ..gpu.profiler import GpuProfiler, profile_every
from ..gpu.uniforms import write_uniform
from ..groom import Groom
from .camera import Camera, look_at, orthographic, perspective
from .coverage_lod import LodPlan, box_corners, lod_plan, mean_width
from .frame_replay import FrameReplay
from .light_key import light_key
from .lights import MAX_LIGHTS, Light, default_lights
from .passes import (ADSMPass, DeepOpacityPass, DensityPass, ExtraShadowsPass, HairPass, HeadPass, OpacityMapsPass,
                     ResolvePass, ShadowMapPass, SkinBouncePass)
from .passes.base import MAX_ISOLINES, Frame, Pass, Target, View, same_box, subdivisions
from .passes import sample_resolve
from .passes.accumulate import AccumulatePass, jittered_view, still_jitter
from .passes.expand import ExpandPass
from .passes.ms_smooth import MsSmoothPass
from .passes.frames import FramesPass
from .passes.extra_shadows import extra_casters, extra_map_size
from .passes.hair_compute import HairComputePass, sample_grid, unsupported_reason, wants_compute
from .passes.oit_pass import OitPass
from .passes.scan_form import ScanForms
from .screen_box import FULL, bound_points, screen_box, union
from .settings import RenderSettings
from .shading import ShadingSettings, hair_preset
from .strand_buffers import StrandBuffers


class ShadingAdapter:
    """The renderer's hair material: ``mane.render.shading`` settings plus a colour override."""

    def __init__(self, name: str = "chiang", hair_color=None, options=None):
        self.name = name
        self.options = dict(options or {})
        self.hair_color = tuple(hair_color) if hair_color is not None else None
        self._defines = None
        self._color = None
        kwargs = {"model": name, **self.options}
        if self.hair_color is not None:
            if self.options.get("melanin") is not None:
                raise UsageError("give the hair colour as melanin or as an RGB hair_color, not both")
            kwargs["color"] = self.hair_color
        if "melanin" in kwargs and isinstance(kwargs["melanin"], str):
            kwargs["melanin"] = hair_preset(kwargs["melanin"])
        try:
            self.settings = ShadingSettings(**kwargs)
        except (TypeError, ValueError) as exc:
            raise UsageError(f"bad shading settings {kwargs}: {exc}") from None

    def defines(self) -> dict:
        if self._defines is None:
            self._defines = dict(self.settings.defines())   # ShadingSettings is frozen
        return dict(self._defines)

    @property
    def color(self) -> tuple:
        """The model's colour (ShadingSettings.resolved_color: melanin's, or the RGB opt-in)."""
        if self._color is None:
            self._color = tuple(float(x) for x in self.settings.resolved_color())   # settings are frozen
        return self._color

    def bind(self, prog, ctx, render_settings=None) -> None:
        self.settings.bind(prog, ctx)


DEFAULT_HEAD_FRAME_FLOOR = -0.30
"""Lowest height (m) the default camera frames on the default bust (mid-chest)."""


_HOMES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # context -> its home framebuffer


def home_framebuffer(ctx):
    """The framebuffer a released renderer gives ``ctx`` back: the one bound when the first
    renderer on ``ctx`` was made (the window's, a caller's, or None). Not simply the one bound
    when this renderer is made: that can be another renderer's target, released first (two
    renderers drawing in turn, released in the order they were made)."""
    if ctx not in _HOMES:
        _HOMES[ctx] = ctx.fbo
    return _HOMES[ctx]


class Renderer(GpuOwner):
    """Renders guide strands (tessellated, multiplied, expanded) and a head into an image."""

    def __init__(self, settings: RenderSettings | None = None, *, ctx=None, profile: bool | int = True,
                 profiler_source: str | None = None):
        self.ctx = ctx if ctx is not None else get_context()
        self._compute_raster = None   # (settings, compute_raster)
        self.memo: dict = {}          # what the passes keep from frame to frame (passes/base.py: the
                                      # lighting and strand uniforms, with what they were made of)
        self._head_model = None       # (head_transform's dtype, shape and bytes, u_head_model's bytes, keeps the winding)
        self.settings = settings if settings is not None else RenderSettings()
        if not isinstance(self.settings, RenderSettings):
            raise UsageError("settings must be a mane.render.RenderSettings")
        max_samples = int(self.ctx.info.get("GL_MAX_SAMPLES", 4) or 4)
        self.samples = max(1, min(int(self.settings.msaa), max_samples))
        self.shading = ShadingAdapter(self.settings.shading, self.settings.hair_color,
                                      self.settings.shading_options)
        every = profile_every(profile)   # True: the profiler's default, N: every Nth frame's passes
        self.profiler = GpuProfiler(self.ctx, enabled=every != 0, source=profiler_source, every=every or None)
        self.scan_forms = ScanForms(self.ctx)   # the compute rasteriser's scan form per site, by measurement
        self.strands: StrandBuffers | None = None
        self.head = None
        self.head_closed = False   # set_head: a closed, outward-wound head (its back faces culled)
        self.head_transform = np.eye(4)
        self._initial_fbo = home_framebuffer(self.ctx)
        self._head_gpu = None
        self._vaos: dict = {}
        self._scene_box = None        # scene_bbox's last box and what it was made from
        self._camera_view = None      # (key, View) of the last camera
        self._light_views: dict = {}  # (light, map size, scene box) -> View
        self._light_views_by_id: dict = {}  # id(light) -> (light, kept scene box, map size, View)
        self._default_lights = None
        self._frames_dirty = True
        self._geometry_version = 0
        self._still = (None, 0)       # (what the last frame showed: _scene_key, its place in a still scene's mean)
        self._still_settings = None   # (settings, still_settings() of them, whether their maps differ)
        self._still_shading_memo = None   # (the frames' ShadingAdapter, a still picture's)
        self._still_twins = {}        # id(light-space pass) -> (the pass, its twin for still frames)
        self._strand_writes = 0       # strands_changed calls (a still scene has none between its frames)
        self._sim_rebuilds = 0        # geometry versions that rebuilt a simulator's frames every frame
        self._targets: dict = {}
        self.frames_rendered = 0
        self.warnings: list[str] = []
        if self.samples < int(self.settings.msaa):
            self.warnings.append(f"{self.settings.msaa}x MSAA asked for; this OpenGL gives at most "
                                 f"{max_samples} samples, using {self.samples}")
        if self.settings.oit != "none" and self.samples > 1:
            # the OIT methods keep fragments per pixel: single-sampled (coverage alpha anti-aliases)
            self.samples = 1
        self._renderer_string = renderer_name(self.ctx)
        self._hdr_resolved = False   # the multisampled HDR target already resolved this frame
        self.sample_offsets = None   # a still frame's samples' pixels on the raster units (passes/sample_resolve.py)
        self._programs = ProgramMemo()   # the renderer's own kernels (the HDR target's clear)
        self._depth_written = None      # (HDR depth texture, the head's screen box last drawn into it)
        self._head_box = None            # (view, transform bytes, the head's screen box, its bounding points)
        if self.compute_raster and not self.settings.head_msaa:
            self.samples = 1
        if not self.compute_raster and wants_compute(self.settings, self._renderer_string) and self.settings.rasterizer == "compute":
            self.warnings.append(unsupported_reason(self))
        self.passes: list[Pass] = [FramesPass(self), ExpandPass(self), ShadowMapPass(self), DeepOpacityPass(self),
                                   ADSMPass(self), OpacityMapsPass(self), DensityPass(self), ExtraShadowsPass(self),
                                   SkinBouncePass(self), HeadPass(self), HairPass(self), HairComputePass(self), MsSmoothPass(self),
                                   OitPass(self),
                                   AccumulatePass(self), ResolvePass(self)]
        self.last_frame: Frame | None = None
        self._released = False
        # multi / hybrid interpolation (mane.render.multi_strand) and distance LOD
        self._guide_weights = None
        self._strand_table = None
        self.collider_sdf = None      # p (M, 3) -> (M,) signed distance; None: from settings / head
        self.lod_eye = None           # the camera's eye of the frame being drawn (LOD distances)
        self.lod_view = None          # the camera's View of the frame being drawn (coverage LOD)
        self.instances = None         # (I, 4, 4) rigid model transforms the groom is drawn at (set_instances)
        self._lod_memo = None
        self.file_appearance: dict = {}   # what the groom's own colours / widths set (set_strands)
        self._scene_look: dict = {}       # the settings' values those replaced, restored for the next groom
        self.on_pass = None           # called with each pass's name after it ran (progress bars)
        self._replay = FrameReplay(self)   # a frame's GL calls issued again while nothing changes

    @property
    def compute_raster(self) -> bool:
        """Whether the hair is drawn by the compute rasteriser this frame (settings.rasterizer);
        kept per settings object (a frame asks a dozen times)."""
        memo = self._compute_raster
        if memo is None or memo[0] is not self.settings:
            memo = self._compute_raster = (self.settings, wants_compute(self.settings, self._renderer_string)
                                           and unsupported_reason(self) is None)
        return memo[1]

    @property
    def raster_grid(self) -> int:
        """The compute rasteriser's samples per pixel side (from settings.msaa)."""
        return sample_grid(self.settings.msaa)

    # ------------------------------------------------------------------ multi-strand interpolation
    def strand_pad(self) -> float:
        """How far (m) a rendered strand may leave its guide (clump, strays, curl)."""
        s = self.settings
        return float(s.clump_radius) * (1.0 + float(s.stray_amount)) + float(s.curl_radius)

    def set_instances(self, transforms) -> None:
        """Draw the groom at every rigid local -> world 4x4 of ``transforms`` (a crowd: one
        groom's guides, many heads), or once where it is (None). Each instance gets its own
        coverage LOD (settings.lod_depth) by how the camera sees it; the expanded strands hold
        only what is kept. Needs pipeline="compute" and no shadows="density"."""
        if transforms is None:
            self.instances = None
        else:
            m = np.asarray(transforms, dtype=np.float64)
            if m.ndim != 3 or m.shape[1:] != (4, 4) or len(m) == 0 or not np.all(np.isfinite(m)):
                raise UsageError("instances must be a non-empty list of finite 4x4 matrices")
            self.instances = m
        self._scene_box = None
        self._light_views.clear()
        self._light_views_by_id.clear()
        self._geometry_version += 1

    def instance_transforms(self) -> np.ndarray:
        """(I, 4, 4): the instances' transforms (one identity without instances)."""
        return self.instances if self.instances is not None else np.eye(4)[None]

    def instance_boxes(self, pad: float = 0.0) -> list:
        """Each instance's world box around the hair (padded by ``pad``): its local box's
        corners transformed."""
        lo, hi = self.strands.bbox()
        if self.instances is None:
            return [(lo - pad, hi + pad)]
        c = np.c_[box_corners(lo - pad, hi + pad), np.ones(8)]
        w = np.einsum("ijk,nk->inj", self.instances, c)[..., :3]
        return list(zip(w.min(axis=1), w.max(axis=1)))

    def hair_bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """The hair's world box (every instance), unpadded."""
        if self.instances is None:
            return self.strands.bbox()
        boxes = self.instance_boxes()
        return (np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0))

    def min_drawn_width_px(self) -> float:
        """The narrowest a strand is drawn (pixels of the render size): the compute rasteriser's
        one sample, the raster units' min_pixel_width."""
        s = self.settings
        if self.compute_raster:
            return 1.0 / self.raster_grid if float(s.min_pixel_width) > 0 else 0.0
        return float(s.min_pixel_width) * int(s.supersample)

    def lod_plan(self, view=None):
        """The coverage LOD's plan (mane.render.coverage_lod) at ``view`` (default: this frame's
        camera): strands kept per guide for each instance. Everything is kept without a view,
        with lod_depth 0 or with multi / hybrid interpolation."""
        s, st = self.settings, self.strands
        view = view if view is not None else self.lod_view
        spg = int(s.strands_per_guide)
        if view is None or not float(s.lod_depth) > 0 or s.interpolation_mode != "single" or st is None:
            instances = len(self.instance_transforms())
            return LodPlan((float("nan"),) * instances, (spg,) * instances, spg)
        # what the plan is made of: the view, the settings, the strands (their guides, mean length and
        # box: a simulator's box and rest length stay) and the instances; not the geometry version,
        # which a simulator moves every frame (the plan cost 0.1-0.3 ms of NumPy a frame)
        lo, hi = st.bbox()
        key = (lo.tobytes(), hi.tobytes(), self.compute_raster)
        memo = self._lod_memo
        if (memo is not None and memo[0] == key and memo[2] is view and memo[3] is s and memo[4] is st
                and memo[5] is self.instances):
            return memo[1]
        plan = lod_plan(view, s.render_size, self.instance_boxes(self.strand_pad()), strands_per_guide=spg,
                        guides=st.num_guides, mean_length=st.mean_length(), mean_width=mean_width(s),
                        min_width_px=self.min_drawn_width_px(), lod_depth=float(s.lod_depth))
        self._lod_memo = (key, plan, view, s, st, self.instances)
        return plan

    def set_guide_weights(self, guide_weights, weights=None, offsets=None) -> None:
        """Rendered strands for multi / hybrid interpolation: grooming's GuideWeights (R strands,
        3 guide indices, 3 barycentric weights, root offsets), or (indices, weights[, offsets])."""
        from .multi_strand import unpack_guide_weights

        self._guide_weights = unpack_guide_weights(guide_weights, weights, offsets)
        self._release_table()

    def set_colliders(self, sdf=None, ellipsoids=None) -> None:
        """Hybrid interpolation's collider: a signed distance function or ellipsoids (cx, cy, cz,
        rx, ry, rz); by default settings.colliders, else the default head's distance field."""
        from .multi_strand import ellipsoid_sdf

        self.collider_sdf = sdf if sdf is not None else (ellipsoid_sdf(ellipsoids) if ellipsoids is not None else None)
        self._release_table()

    def hybrid_sdf(self):
        if self.collider_sdf is not None:
            return self.collider_sdf
        if self.settings.colliders:
            from .multi_strand import ellipsoid_sdf

            return ellipsoid_sdf(self.settings.colliders)
        head = self.head
        if head is not None and str(getattr(head, "metadata", {}).get("source", "")).endswith("default_head"):
            from ..grooming.head import head_sdf

            return head_sdf
        return None

    def _release_table(self) -> None:
        if self._strand_table is not None:
            self._strand_table.release()
            self._strand_table = None
        self._geometry_version += 1

    def strand_table(self):
        """The multi / hybrid strand records on the GPU (built on first use)."""
        from .multi_strand import StrandTable

        if self._strand_table is None:
            st = self.strands
            if self._guide_weights is not None:
                idx, w, off = self._guide_weights
                table = StrandTable(self.ctx, idx, w, off, num_guides=st.num_guides)
            else:
                roots = st.read_positions()[:, 0]
                table = StrandTable.procedural(self.ctx, roots, int(self.settings.strands_per_guide),
                                               bool(self.settings.keep_guide), st.guide_triangles)
            if self.settings.interpolation_mode == "hybrid":
                sdf = self.hybrid_sdf()
                if sdf is None:
                    self.warnings.append("hybrid interpolation without a collider (settings.colliders or "
                                         "set_colliders): every strand is blended")
                else:
                    table.set_hybrid_flags(st.read_positions(), sdf, float(self.settings.hybrid_margin))
            self._strand_table = table
            self._geometry_version += 1   # expand again, from the table
        return self._strand_table

    def update_hybrid(self) -> None:
        """Recompute the hybrid flags from the current guide positions (after simulation steps)."""
        self._release_table()

    def get_pass(self, name: str) -> Pass:
        """The pass called ``name`` ("shadow_map", "deep_opacity", "adsm", "opacity_maps", "density", ...)."""
        for p in self.passes:
            if p.name == name:
                return p
        raise KeyError(name)

    # ------------------------------------------------------------------ scene
    def set_strands(self, strands, points_per_strand: int | None = None) -> StrandBuffers:
        """A StrandBuffers, a Simulator (its positions SSBO is read in place) or a Groom (uploaded)."""
        if self.strands is not None and self.strands is not strands:
            self.strands.release()
        if isinstance(strands, StrandBuffers):
            self.strands = strands
        elif hasattr(strands, "state") and hasattr(strands.state, "positions"):
            self.strands = StrandBuffers.from_simulator(strands)
        elif isinstance(strands, Groom):
            self.strands = StrandBuffers.from_groom(self.ctx, strands, points_per_strand)
        else:
            raise UsageError(f"strands must be a mane.Groom, a mane.sim.Simulator or StrandBuffers, "
                             f"got {type(strands).__name__}")
        groom = getattr(strands, "groom", strands) if not isinstance(strands, StrandBuffers) else None
        self._apply_file_appearance(groom)
        self._frames_dirty = True
        self._release_table()
        return self.strands

    def _apply_file_appearance(self, groom) -> None:
        """The groom's own colour, width and opacity (settings.use_file_colors; file_appearance.py)."""
        from dataclasses import replace

        from .file_appearance import file_appearance

        before = self.settings
        if self.file_appearance:   # the previous groom's look belonged to that groom only
            self.settings = replace(self.settings, **self._scene_look)
        self.file_appearance, self._scene_look = {}, {}
        if self.settings.use_file_colors and isinstance(groom, Groom) and "frame" in groom.metadata:
            # only a groom read from a file (mane.load records its frame); grown ones keep the scene's look
            self.file_appearance = file_appearance(groom)
            self._scene_look = {k: getattr(self.settings, k) for k in self.file_appearance}
            self.settings = replace(self.settings, **self.file_appearance)
        if self.settings != before:
            self.shading = ShadingAdapter(self.settings.shading, self.settings.hair_color,
                                          self.settings.shading_options)

    def strands_changed(self) -> None:
        """Positions were written (a simulation step): rebuild the frames on the next render."""
        self._frames_dirty = True
        self._strand_writes += 1

    @property
    def frames_dirty(self) -> bool:
        """Whether the guides' frames must be rebuilt before the strands are drawn."""
        return self._frames_dirty

    @property
    def geometry_version(self) -> int:
        """Counts changes of the rendered geometry (new frames, a new or dropped strand table):
        what the expand pass keys its buffer on."""
        return self._geometry_version

    def rebuild_frames(self) -> None:
        """Rebuild the guides' transported frames from the current positions (the frames pass)."""
        self.strands.update_frames()
        self._geometry_version += 1   # pipeline="compute": expand again
        # a simulator's buffer changes behind our back: rebuild every frame
        self._frames_dirty = not self.strands.owns_positions
        self._sim_rebuilds += self._frames_dirty

    def set_head(self, mesh) -> None:
        if self._head_gpu is not None:
            for o in self._head_gpu:
                o.release()
            self._head_gpu = None
            self._vaos = {k: v for k, v in self._vaos.items() if k[0] != "head"}
        self.head = mesh
        self.head_closed = False
        self._head_box = None   # the same mesh object may come back with other vertices
        if mesh is None:
            return
        self.head_closed = mesh.closed_outward()   # the head pass culls its back faces then
        scalp = mesh.vertex_attributes.get("scalp")
        if scalp is None:
            scalp = np.zeros(len(mesh.vertices), np.float32)
        data = np.concatenate([mesh.vertices.astype(np.float32), mesh.normals.astype(np.float32),
                               np.asarray(scalp, np.float32).reshape(-1, 1)], axis=1)
        vbo = self.ctx.buffer(np.ascontiguousarray(data).tobytes())
        ibo = self.ctx.buffer(mesh.faces.astype(np.int32).tobytes())
        self._head_gpu = (vbo, ibo)

    def set_head_transform(self, matrix) -> None:
        """The head mesh's rigid local -> world 4x4 (a simulator's head motion), metres."""
        m = np.asarray(matrix, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise UsageError("the head transform must be a finite 4x4 matrix")
        self.head_transform = m

    def draw_head(self, prog, cull_back: bool = False) -> None:
        """Draw the head mesh with ``prog`` (which declares ``u_head_model``) at its current
        transform. ``cull_back``: a closed head wound outward (``head_closed``) shows only its
        front faces, and its nearest depth from any view is one of them: its back faces are
        culled (half the fragments; not under a mirroring transform, nor for an open or flipped
        mesh)."""
        model, keeps_winding = self.head_model()
        write_uniform(prog["u_head_model"], model)
        cull = cull_back and self.head_closed and keeps_winding
        if cull:
            self.ctx.cull_face = "back"
            self.ctx.front_face = "ccw"
            self.ctx.enable(self.ctx.CULL_FACE)
        try:
            self.head_vao(prog).render()
        finally:
            if cull:
                self.ctx.disable(self.ctx.CULL_FACE)

    def head_buffers(self):
        """The head mesh's (vertex buffer: 7 floats a vertex, position, normal, scalp weight;
        index buffer: 3 int32 a triangle), or None without a head."""
        return self._head_gpu

    def head_model(self) -> tuple[bytes, bool]:
        """The head transform as ``u_head_model``'s bytes and whether it keeps the winding (a
        positive determinant: the head pass may cull back faces); made again when the transform's
        values change."""
        m = np.asarray(self.head_transform)
        raw = (m.dtype.str, m.shape, m.tobytes())
        memo = self._head_model
        if memo is None or memo[0] != raw:
            memo = self._head_model = (raw, np.ascontiguousarray(m.T, dtype=np.float32).tobytes(),
                                       float(np.linalg.det(m[:3, :3])) > 0.0)
        return memo[1], memo[2]

    def head_vao(self, prog):
        key = ("head", id(prog))
        if key not in self._vaos:
            vbo, ibo = self._head_gpu
            names = [n for n in ("in_position", "in_normal", "in_scalp") if n in prog]
            fmt = " ".join(("3f" if n != "in_scalp" else "1f") if n in names else
                           ("12x" if n != "in_scalp" else "4x") for n in ("in_position", "in_normal", "in_scalp"))
            self._vaos[key] = self.ctx.vertex_array(prog, [(vbo, fmt, *names)], index_buffer=ibo,
                                                    index_element_size=4)
        return self._vaos[key]

    def empty_vao(self, prog):
        key = ("empty", id(prog))
        if key not in self._vaos:
            self._vaos[key] = self.ctx.vertex_array(prog, [])
        return self._vaos[key]

    def hair_color(self) -> tuple:
        return self.shading.color

    def scene_bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """The hair's box (padded by strand_pad) and the head's, around the world's axes."""
        lo, hi = self._kept_scene_box()
        return lo.copy(), hi.copy()

    def _kept_scene_box(self) -> tuple:
        """scene_bbox's (lo, hi) as kept (not to be changed): one tuple object while the box is
        the same."""
        st_box = self.hair_bbox() if self.strands is not None else None
        pad = self.strand_pad() if st_box is not None else 0.0
        draw_head = self.head is not None and bool(self.settings.draw_head)
        key = (pad, draw_head)
        memo = self._scene_box
        # the strands keep their box until it is refreshed (a new tuple); the head until set_head
        if (memo is None or not same_box(memo[0], st_box) or memo[1] is not self.head
                or memo[2] != key):
            los, his = [], []
            if st_box is not None:
                los.append(st_box[0] - pad)
                his.append(st_box[1] + pad)
            if draw_head:
                lo, hi = self.head.bbox()
                los.append(lo)
                his.append(hi)
            if not los:
                box = (np.full(3, -0.5), np.full(3, 0.5))
            else:
                box = (np.min(los, axis=0).astype(float), np.max(his, axis=0).astype(float))
            memo = self._scene_box = (st_box, self.head, key, box)
        return memo[3]

    def scene_center(self) -> np.ndarray:
        lo, hi = self.scene_bbox()
        return 0.5 * (lo + hi)

    def framing_bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """What the default camera frames: the hair, and the head down to a little below it (on
        the default bust no lower than mid-chest: a head-and-shoulders frame)."""
        if self.strands is None:
            return self.scene_bbox()
        lo, hi = self.hair_bbox()
        pad = self.strand_pad()
        lo, hi = lo - pad, hi + pad
        if self.head is not None and self.settings.draw_head:
            v = self.head.vertices
            floor = lo[1] - 0.04 * (hi[1] - lo[1])
            if str(getattr(self.head, "metadata", {}).get("source", "")).endswith("default_head"):
                # the default bust: head and shoulders, down to the middle of the chest
                floor = max(floor, DEFAULT_HEAD_FRAME_FLOOR)
                lo[1] = max(lo[1], floor)
            v = v[v[:, 1] >= floor]
            if len(v):
                lo, hi = np.minimum(lo, v.min(axis=0)), np.maximum(hi, v.max(axis=0))
        return lo.astype(float), hi.astype(float)

    def framing_points(self, max_points: int = 20000) -> np.ndarray | None:
        """What the default camera fits: points of the hair (at most ``max_points``) and the
        head's vertices inside ``framing_bbox`` (head and shoulders down to the hair's ends)."""
        if self.strands is None:
            return None
        p = self.strands.read_positions()[..., :3].reshape(-1, 3).astype(np.float64)
        if self.instances is not None:   # every instance's points
            p = np.einsum("ijk,nk->inj", self.instances, np.c_[p, np.ones(len(p))])[..., :3].reshape(-1, 3)
        if len(p) > max_points:
            p = p[np.linspace(0, len(p) - 1, max_points).astype(np.int64)]
        lo, hi = self.framing_bbox()
        p = p[p[:, 1] >= lo[1]]
        if self.head is not None and self.settings.draw_head:
            v = self.head.vertices.astype(np.float64)
            v = v[np.all((v >= lo) & (v <= hi), axis=1)]
            p = np.concatenate([p, v])
        return p

    def default_camera(self, azimuth: float = 25.0, elevation: float = 12.0, **kw) -> Camera:
        """The default framing; ``points`` (default: ``framing_points()``, which reads the guides
        back from the GPU) are what it fits, None: the box alone (no read-back)."""
        lo, hi = self.framing_bbox()
        w, h = self.settings.size
        if "points" not in kw:   # not setdefault: its argument would read the guides back regardless
            kw["points"] = self.framing_points()
        return Camera.framing(lo, hi, azimuth=azimuth, elevation=elevation, aspect=w / h, **kw)

    # ------------------------------------------------------------------ targets
    def hdr_fbo(self):
        if "hdr" not in self._targets:
            size = self.settings.render_size
            ctx = self.ctx
            from ..gpu.buffers import check_texture

            # the multisampled colour (RGBA16F) and depth (32-bit) plus their resolved copies and
            # the output (RGBA8), checked together before any is made
            px = size[0] * size[1]
            check_texture(ctx, size, 1, 12, f"the {size[0]}x{size[1]} render targets ({self.samples} samples)",
                          samples=self.samples, extra_bytes=px * 12 * (self.samples > 1) + 4 * px,
                          reduce="Use a smaller --size, fewer MSAA samples (--aa) or no supersampling")
            if self.samples > 1:   # the colour a texture: a still frame's resolve reads its samples (sample_resolve.py)
                color = ctx.texture(size, 4, samples=self.samples, dtype="f2")
                depth = ctx.depth_renderbuffer(size, samples=self.samples)
                tex = ctx.texture(size, 4, dtype="f2")
                dtex = ctx.depth_texture(size)   # the compute rasteriser tests the hair against it
                dtex.compare_func = ""
                self._targets["hdr_resolved"] = Target(ctx.framebuffer([tex], dtex), tex, dtex)
            else:   # textures: the compute rasteriser reads the depth and writes the colour
                color = ctx.texture(size, 4, dtype="f2")
                depth = ctx.depth_texture(size)
                depth.compare_func = ""
            self._targets["hdr"] = Target(ctx.framebuffer([color], depth), color, depth)
        return self._targets["hdr"].fbo

    def _clear_hdr(self, fbo, view) -> None:
        """Clear the HDR target to transparent black and depth 1. With the compute rasteriser and
        one sample the colour is cleared by a compute shader (mane.gpu.clear: on an H200 0.01
        against 0.29 ms at 1080p), and the depth, which only the head writes there, by the raster
        units over the head's screen box of this frame and the last (screen_box)."""
        if self.samples > 1 or not self.compute_raster:
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            return
        target = self._targets["hdr"]
        if "hdr_depth" not in self._targets:
            self._targets["hdr_depth"] = (self.ctx.framebuffer(depth_attachment=target.depth),)
        box = self.head_screen_box(view)
        written = self._depth_written   # (the depth texture, the box its last frame's head wrote)
        area = union(box, written[1] if written is not None and written[0] is target.depth else FULL)
        if area == FULL:
            self._targets["hdr_depth"][0].clear(depth=1.0)
        elif area is not None:
            self._targets["hdr_depth"][0].clear(depth=1.0, viewport=area)
        self._depth_written = (target.depth, box)
        clear_texture(self.ctx, target.color, programs=self._programs)
        fbo.use()

    def head_screen_box(self, view):
        """The head's screen box in ``view`` (screen_box; None without a head drawn), kept while
        the view, the head and its transform are the same."""
        if self.head is None or not self.settings.draw_head:
            return None
        model = self.head_model()[0]
        memo = self._head_box   # (set_head forgets it)
        if memo is not None and memo[0] is view and memo[1] == model:
            return memo[2]
        points = memo[3] if memo is not None else bound_points(self.head.vertices)
        box = screen_box(view.view_proj, points, self.head_transform, self.settings.render_size)   # the target's pixels
        self._head_box = (view, model, box, points)
        return box

    def hdr_target(self) -> Target:
        """The HDR target as drawn into: its framebuffer, colour and depth (with MSAA a
        multisampled texture and depth renderbuffer, else textures); made on first use."""
        self.hdr_fbo()
        return self._targets["hdr"]

    def hdr_textures(self):
        """The HDR target's (colour, depth) as single-sample textures: with MSAA the target is
        resolved into them now (colour averaged, depth of a sample), and later passes (the
        compute rasteriser's shading, then resolve) work on the resolved colour."""
        self.hdr_fbo()
        if self.samples > 1:
            self.resolved_hdr()
            _, color, depth = self._targets["hdr_resolved"]
            return color, depth
        _, color, depth = self._targets["hdr"]
        return color, depth

    def resolved_hdr(self):
        """The HDR colour as a single-sample texture (blitting the MSAA target into it once a
        frame)."""
        fbo, color, _ = self._targets["hdr"]
        if self.samples > 1:
            dst, tex, _ = self._targets["hdr_resolved"]
            if not self._hdr_resolved:
                self.ctx.copy_framebuffer(dst, fbo)   # colour and depth (the compute passes test against it)
                if self.sample_offsets is not None:   # a still frame: the colour again, from the samples that fell in each pixel
                    sample_resolve.resolve(self, color, dst, self.sample_offsets)
                self._hdr_resolved = True
            return tex
        return color

    def output_fbo(self):
        return self.output_target()[0]

    def output_target(self):
        """(framebuffer, texture) of the final 8-bit image (made on first use)."""
        if "output" not in self._targets:
            tex = self.ctx.texture(self.settings.size, 4)
            self._targets["output"] = (self.ctx.framebuffer([tex]), tex)
        return self._targets["output"]

    # ------------------------------------------------------------------ views
    def camera_view(self, camera: Camera) -> View:
        """The camera's View (kept while the camera and the settings it depends on are the same:
        its uniforms are then made once)."""
        s = self.settings
        try:
            key = (camera, s.render_size, s.min_pixel_width, s.supersample)
            memo = self._camera_view
            if memo is not None and memo[0] == key:
                return memo[1]
        except TypeError:   # a camera made with lists: nothing kept
            key = None
        view = self._camera_view_of(camera)
        self._camera_view = (key, view) if key is not None else None
        return view

    def _camera_view_of(self, camera: Camera) -> View:
        w, h = self.settings.render_size
        vp = camera.projection(w / h) @ camera.view()
        pixel = 2.0 * math.tan(math.radians(camera.fov_y) / 2.0) / h
        min_px = float(self.settings.min_pixel_width) * self.settings.supersample
        return View(vp, np.asarray(camera.eye, float), camera.forward, False, pixel, min_px)

    def light_view(self, light: Light, size: int | None = None) -> View:
        """A light's view fitted around the scene's bounding sphere, for a map of ``size`` texels a
        side (default shadow_map_size, light 0's) (kept while the light, the scene's box and the
        map size are the same; found by identity first: the same light object and kept box, as
        every frame of a still scene asks)."""
        box = self._kept_scene_box()
        n = int(self.settings.shadow_map_size if size is None else size)
        last = self._light_views_by_id.get(id(light))
        if last is not None and last[0] is light and last[1] is box and last[2] == n:
            return last[3]
        lo, hi = box
        key = (light, n, lo.tobytes(), hi.tobytes())
        try:
            view = self._light_views.get(key)
        except TypeError:   # an unhashable light: nothing kept
            return self._light_view_of(light, lo.copy(), hi.copy(), n)
        if view is None:
            if len(self._light_views) >= 4 * MAX_LIGHTS:
                self._light_views.clear()
            view = self._light_views[key] = self._light_view_of(light, lo.copy(), hi.copy(), n)
        if len(self._light_views_by_id) >= 4 * MAX_LIGHTS:   # new light objects every frame (a viewer)
            self._light_views_by_id.clear()
        self._light_views_by_id[id(light)] = (light, box, n, view)
        return view

    def _light_view_of(self, light: Light, lo, hi, n: int) -> View:
        center = 0.5 * (lo + hi)
        radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-3)
        min_px = 1.0   # a strand covers at least a texel in the maps, with its coverage as opacity
        if light.is_point:
            eye = np.asarray(light.vector, float)
            dist = float(np.linalg.norm(center - eye))
            if dist <= radius * 1.05:
                raise UsageError("the shadowing point light is inside the scene's bounds; move it "
                                 "out or use a directional light")
            fov = 2.0 * math.degrees(math.asin(radius / dist)) * 1.05
            view = look_at(eye, center)
            proj = perspective(fov, 1.0, max(1e-3, dist - radius * 1.1), dist + radius * 1.1)
            pixel = 2.0 * math.tan(math.radians(fov) / 2.0) / n
            fwd = (center - eye) / dist
            return View(proj @ view, eye, fwd, False, pixel, min_px)
        d = light.direction_to(center)
        eye = center + d * radius * 2.0
        view = look_at(eye, center)
        proj = orthographic(radius * 1.02, radius * 1.02, radius * 0.5, radius * 3.5)
        return View(proj @ view, eye, -d, True, 2.0 * radius * 1.02 / n, min_px)

    def _hair_depth_range(self, lv: View) -> tuple[float, float]:
        if self.strands is None:
            return (0.0, 1.0)
        box = self.hair_bbox()
        pad = self.strand_pad()
        memo = lv.__dict__.get("_hair_depth_range")   # kept on the (kept) light view
        if memo is not None and same_box(memo[0], box) and memo[1] == pad:
            return memo[2]
        lo, hi = box
        lo, hi = lo - pad, hi + pad
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        z = (corners - lv.eye) @ lv.forward
        out = (float(z.min()), float(z.max()))
        lv.__dict__["_hair_depth_range"] = (box, pad, out)
        return out

    # ------------------------------------------------------------------ rendering
    def render(self, camera: Camera | None = None, lights: list[Light] | None = None, *, refine: bool = False) -> Frame:
        """Draw a frame. ``refine``: a frame of a still scene (the same camera, lights, hair and
        settings as the last frame, itself drawn with ``refine``) is moved by a sub-pixel offset
        and folded into the still picture's mean, which the output shows (settings.accumulate,
        passes/accumulate.py; the viewer refines, render_still does); without it the frame is
        drawn at the pixel centres and shown as it is."""
        camera = camera if camera is not None else self.default_camera()
        if lights is None:
            if self._default_lights is None:
                self._default_lights = tuple(default_lights())   # Lights are frozen
            lights = self._default_lights
        lights = list(lights)
        if len(lights) > MAX_LIGHTS:
            raise UsageError(f"at most {MAX_LIGHTS} lights, got {len(lights)}")
        if not all(isinstance(light, Light) for light in lights):
            raise UsageError(f"lights must be mane.render.Light objects, got "
                             f"{', '.join(sorted({type(x).__name__ for x in lights if not isinstance(x, Light)}))}")
        if not isinstance(camera, Camera):
            raise UsageError(f"camera must be a mane.render.Camera, got {type(camera).__name__}")
        one = self.settings.oit != "none" or (self.compute_raster and not self.settings.head_msaa)
        if one and self.samples > 1:
            self._single_sample()   # settings switched after construction (a viewer)
        replay = self._replay
        action, phase = replay.plan(camera, tuple(lights), refine)
        if action == "play":   # a frame drawn twice the same: its recorded GL calls (frame_replay.py)
            take = replay.play(phase)
            frame = copy.copy(take.frame)
            frame.index = self.frames_rendered
            self._hdr_resolved, self.sample_offsets = take.resolved, None
            return self._close_frame(frame, (None, 0))
        if action in ("draw", "timed"):
            if action == "draw":
                replay.drawn()
            return self._draw(camera, lights, refine)
        try:
            with gl_replay.record(strict=False) as rec:   # None while another thread records
                frame = self._draw(camera, lights, refine)
        except BaseException:
            replay.forget(keep_view=True)   # a frame cut short: nothing recorded stands for the next
            raise
        if rec is None:
            replay.drawn()
        else:
            replay.recorded(phase, rec, frame, verify=action == "verify")
        return frame

    def _draw(self, camera: Camera, lights: list, refine: bool) -> Frame:
        """A frame's passes (render, frame_replay.py's frames not played)."""
        self._hdr_resolved = False
        self.sample_offsets = None
        still = self._still_place(camera, lights) if refine else 0
        base, passes, shading = self.settings, self.passes, self.shading
        if 1 <= still <= int(base.accumulate) and self.still_settings() is not base:
            # a still picture's frames in its mean: its own, finer shadow and opacity maps
            self.shading = self._still_shading(base, self.still_settings())
            self.settings = self.still_settings()
        try:
            if self.settings is not base and self._still_settings[2]:   # (not the shading alone)
                passes = self._still_passes()
            view = self.camera_view(camera)
            frame = Frame(self, camera, lights, self._still_view(view, still), index=self.frames_rendered, still=still)
            self.lod_eye = view.eye
            self.lod_view = view   # the LOD's plan is kept while the still frames' views move
            if self.instances is not None:
                from .passes.expand import pulls

                if not pulls(self) or self.settings.shadows == "density":
                    raise UsageError("instances (set_instances) are drawn from the expanded strands: they need "
                                     "pipeline='compute', a compute or no OIT method, and a shadow method other "
                                     "than 'density'")
            if lights and self.settings.shadows != "none":
                frame.light_view = self.light_view(lights[0])
                frame.hair_depth_range = self._hair_depth_range(frame.light_view)
                extra = extra_map_size(self.settings)
                for light in extra_casters(self.settings, lights):   # more lights that cast
                    lv = self.light_view(light, extra)
                    frame.shadow_views.append((lv, self._hair_depth_range(lv)))
            fbo = self.hdr_fbo()
            fbo.use()
            with self.profiler.section("clear"):   # a multisampled target's clear is not free (H200)
                self._clear_hdr(fbo, frame.view)
            on_pass = self.on_pass
            key = None
            for p in passes:
                if not p.enabled(frame):
                    p.kept = None
                elif p.light_space:   # reused while the lights, the hair and the head are still (light_key.py)
                    if key is None:
                        key = light_key(self, frame) or False
                    if key and key.matches(p.kept[0] if p.kept is not None else None):
                        frame.targets.update(p.kept[1])
                        frame.kept.append(p.name)
                    else:
                        before = dict(frame.targets)
                        with self.profiler.section(p.name):
                            p.run(frame)
                        p.kept = (key, {k: v for k, v in frame.targets.items() if before.get(k) is not v}) if key else None
                else:
                    with self.profiler.section(p.name):
                        p.run(frame)
                if on_pass is not None:
                    on_pass(p.name)
        except GPUMemoryError:
            if passes is self.passes and self.settings is base:
                raise
            # the finer maps do not fit: the frames' own from now on, and this frame again with them
            self.settings, self.shading = base, shading
            self._drop_still_settings()
            return self._draw(camera, lights, refine)
        finally:
            self.settings, self.shading = base, shading
        return self._close_frame(frame, (self._scene_key(camera, lights), still) if refine else (None, 0))

    def _close_frame(self, frame: Frame, still: tuple) -> Frame:
        """A frame drawn or played: counted, kept as the last, and its place in a still scene."""
        self.profiler.frame()
        self.frames_rendered += 1
        self.last_frame = frame
        self._still = still
        return frame

    def still_settings(self) -> RenderSettings:
        """The settings a still picture's frames in its mean are drawn with: the shadow and
        opacity maps at settings.still_shadow_map_size, lowered to what the GPU's storage blocks
        and textures hold, with still_dom_layers, the extra lights' at still_extra_shadow_map_size,
        still_segments, and Chiang's near field with still_near_field; the settings themselves
        where that is no finer.
        The same object while the settings are (light_key.py keeps the maps by it)."""
        s = self.settings
        memo = self._still_settings
        if memo is not None and memo[0] is s:
            return memo[1]
        changes = {}
        n = self._fitting_map(int(s.still_shadow_map_size), int(s.shadow_map_size))
        if n > int(s.shadow_map_size):
            changes.update(shadow_map_size=n, dom_layers=tuple(s.still_dom_layers))
        x = min(self._fitting_map(int(s.still_extra_shadow_map_size), extra_map_size(s)), max(n, int(s.shadow_map_size)))
        if x > extra_map_size(s) and int(s.shadow_lights) > 1:
            changes["extra_shadow_map_size"] = x
        if int(s.still_segments) > int(s.segments):
            changes["segments"] = int(s.still_segments)
        maps = bool(changes)   # the light-space passes' twins draw their own maps (_still_passes)
        if s.still_near_field and s.shading == "chiang" and not s.shading_options.get("near_field"):
            changes["shading_options"] = {**s.shading_options, "near_field": True}
        out = s.replace(**changes) if changes else s
        self._still_settings = (s, out, maps)
        return out

    def _still_shading(self, base: RenderSettings, still: RenderSettings) -> ShadingAdapter:
        """The hair material of a still picture's frames (drawn with ``still``, the still_settings()
        of the frames' ``base``): the frames' own, with the still settings' shading options where
        they differ (Chiang's near field, still_near_field). Kept while the frames' material is."""
        if still.shading_options is base.shading_options:
            return self.shading
        memo = self._still_shading_memo
        if memo is None or memo[0] is not self.shading:
            memo = self._still_shading_memo = (self.shading, ShadingAdapter(still.shading, still.hair_color,
                                                                             still.shading_options))
        return memo[1]

    def _fitting_map(self, n: int, base: int) -> int:
        """``n`` texels a side halved until the GPU's storage blocks and textures hold such a map
        (deep_opacity.py's counters: 16 bytes a texel), no lower than ``base``."""
        if n <= base:
            return n
        from ..gpu.capabilities import get_capabilities

        limits = get_capabilities(self.ctx).limits
        block = int(limits.get("max_shader_storage_block_size") or 1 << 27)
        side = int(limits.get("max_texture_size") or 16384)
        while n > base and (n * n * 16 > block or n > side):
            n //= 2
        return n

    def frame_settings(self) -> RenderSettings:
        """The settings frames are drawn with: ``settings``, also while a still picture's frame is
        drawn with still_settings()."""
        memo = self._still_settings
        return memo[0] if memo is not None and self.settings is memo[1] else self.settings

    def _drop_still_settings(self) -> None:
        """Still pictures are drawn as the frames are (their finer maps or segments did not fit the
        GPU; or the renderer is released): the twins released, still_settings() the settings."""
        for _, twin in self._still_twins.values():
            twin.release()
        self._still_twins.clear()
        self._still_settings = (self.settings, self.settings, False)

    def _still_passes(self) -> list:
        """The passes of a still picture's frames in its mean: each light-space pass (Pass.light_space)
        has a twin made under still_settings, with targets of its own at their size, so that
        neither set of maps is made again when frames go from moving to still and back."""
        out = []
        for p in self.passes:
            if p.light_space:
                twin = self._still_twins.get(id(p))
                if twin is None or twin[0] is not p:
                    twin = self._still_twins[id(p)] = (p, type(p)(self))
                p = twin[1]
            out.append(p)
        return out

    def _scene_key(self, camera, lights) -> tuple:
        """What a frame shows besides its targets: equal keys on consecutive frames make a still
        scene (passes/accumulate.py)."""
        return (camera, tuple(lights), self.settings, self.hair_version(), id(self.strands), id(self.head),
                self.head_model()[0] if self.head is not None else None, id(self.instances))

    def hair_version(self) -> tuple:
        """Changes when the drawn hair's positions may have: the geometry version, strands_changed
        calls and a simulator's steps. A simulator's buffer counts as changed when the simulator
        has stepped (or strands_changed was called), not by the frames rebuilt from it every frame."""
        st = self.strands
        steps = None if st is None or st.owns_positions else getattr(getattr(st.source, "state", None), "steps", None)
        return (self._geometry_version - self._sim_rebuilds, self._strand_writes, steps)

    def _still_place(self, camera, lights) -> int:
        """A refining frame's place in a still scene's mean: 0 when anything changed since the
        last frame (or a simulation writes the hair), else one more than the last frame's."""
        if int(self.settings.accumulate) < 2:
            return 0
        key, place = self._still
        return place + 1 if key == self._scene_key(camera, lights) else 0

    def _still_view(self, view: View, still: int) -> View:
        """The camera's ``view``, moved by the still frame's sub-pixel offset while the mean grows."""
        if not 1 <= still <= int(self.settings.accumulate):
            return view
        if self.compute_raster and self.settings.oit == "none":
            dx, dy = still_jitter(still, self.raster_grid)
        elif self.samples > 1:   # the raster units' samples: anywhere in the pixel, each resolved from where it fell
            positions = sample_resolve.sample_positions(self)
            dx, dy = sample_resolve.jitter(positions, still)
            self.sample_offsets = sample_resolve.offsets(positions, (dx, dy))
        else:
            dx, dy = still_jitter(still, 1)
        return jittered_view(view, dx, dy, self.settings.render_size)

    @property
    def still_frames(self) -> int:
        """The frames in the mean the last frame showed (0: that frame alone; at most
        settings.accumulate)."""
        return min(self._still[1], int(self.settings.accumulate))

    def shown_hdr(self, place: int | None = None):
        """The linear HDR colour the output shows at a frame's ``place`` in a still scene's mean
        (default: the last frame's): the mean (RGBA32F) from place 1 on, else the frame's own
        target (resolved_hdr, blitting a multisampled one)."""
        place = self._still[1] if place is None else place
        mean = self.get_pass("accumulate").texture
        if place >= 1 and int(self.settings.accumulate) >= 2 and mean is not None:
            return mean
        return self.resolved_hdr()

    def render_still(self, camera: Camera | None = None, lights=None) -> np.ndarray:
        """Render a still picture: the refining frames its mean still needs (settings.accumulate;
        one frame when that is 1, or when the hair changes every frame), then read_image."""
        camera = camera if camera is not None else self.default_camera()
        n = int(self.settings.accumulate)
        self.render(camera, lights, refine=True)
        while n >= 2 and self.still_frames < n:
            before = self._still[1]
            self.render(camera, lights, refine=True)
            if self._still[1] <= before:   # the scene changed: a simulation's buffer
                break
        return self.read_image()

    def read_image(self) -> np.ndarray:
        """(H, W, 3) uint8 sRGB of the last frame, top row first."""
        w, h = self.settings.size
        raw = self.output_fbo().read(components=3, alignment=1)
        return np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1].copy()

    def render_image(self, camera: Camera | None = None, lights=None) -> np.ndarray:
        self.render(camera, lights)
        return self.read_image()

    # ------------------------------------------------------------------ numbers
    @property
    def rendered_strands(self) -> int:
        if self.strands is None:
            return 0
        if self.settings.interpolation_mode != "single":
            if self._guide_weights is not None:
                return len(self._guide_weights[0])
        return self.strands.num_guides * int(self.settings.strands_per_guide)

    @property
    def rendered_segments(self) -> int:
        """Segments drawn a frame (with the distance LOD: at the last frame's camera; multi /
        hybrid interpolation with LOD counts every strand at full level)."""
        if self.strands is None:
            return 0
        st = self.strands
        per = subdivisions(self.settings, st.points_per_strand)
        if self.settings.lod and self.lod_eye is not None and self.settings.interpolation_mode == "single":
            # what the last frame drew: each guide's level and strands at its distance
            from .passes.expand import pulls
            from .strand_math import lod_segments_drawn

            return lod_segments_drawn(st.read_positions()[:, 0], self.lod_eye, self.settings, st.points_per_strand,
                                      per, tessellation=not pulls(self))
        return self.segment_capacity

    @property
    def segment_capacity(self) -> int:
        """The most segments one frame can draw (with the LOD: every strand at its nearest
        level, fractional_odd_spacing's count): what capture buffers are sized for."""
        if self.strands is None:
            return 0
        st = self.strands
        per = subdivisions(self.settings, st.points_per_strand)
        if self.settings.lod:
            from .strand_math import lod_level, odd_spacing_count

            per = int(odd_spacing_count(lod_level(0.0, self.settings.replace(lod=False), st.points_per_strand)))
        return self.rendered_strands * (st.points_per_strand - 1) * per

    def stats(self) -> dict:
        return {
            "passes": {k: round(v, 4) for k, v in self.profiler.means(wait=True).items()},
            "frames": self.frames_rendered,
            "frames_replayed": self._replay.played,   # frames issued from a recording (frame_replay.py)
            "still_frames": self.still_frames,
            "size": list(self.settings.size),
            "renderer": renderer_name(self.ctx),
            "timing": self.profiler.source,
            "rendered_strands": self.rendered_strands,
            "rendered_segments": self.rendered_segments,
            **self.lod_stats(),
            "guides": 0 if self.strands is None else self.strands.num_guides,
            "points_per_guide": 0 if self.strands is None else self.strands.points_per_strand,
            "msaa": self.samples,
            "rasterizer": "compute" if self.compute_raster else "hardware",
            "scan_form": self.scan_forms.stats(),
            "scan_form_by": self.scan_forms.by(),
            "reused_passes": list(self.last_frame.kept) if self.last_frame is not None else [],   # light_key.py
            "raster_samples": self.raster_grid ** 2 if self.compute_raster else self.samples,
            "supersample": self.settings.supersample,
            "shadows": self.settings.shadows,
            "interpolation": self.settings.interpolation,
            "geometry": self.settings.geometry,
            "shading": self.shading.name,
            "instances_per_guide_segment": math.ceil(int(self.settings.strands_per_guide) / MAX_ISOLINES),
            **self.oit_stats(),
        }

    def lod_stats(self) -> dict:
        """The coverage LOD of the last frame: instances, their estimated depth complexity,
        strands expanded (what every pass drew) and their share of the groom's."""
        if self.strands is None:
            return {}
        plan = self.lod_plan()
        full = len(plan.kept) * self.rendered_strands
        drawn = self.get_pass("expand").strands if self.get_pass("expand").buffer is not None else None
        d = [x for x in plan.depth if np.isfinite(x)]
        dom = next((p for p in self.passes if p.name == "deep_opacity"), None)
        step = dom.last_step if dom is not None else None
        return {"lod_depth": float(self.settings.lod_depth), "instances": len(plan.kept),
                "lod_depth_complexity": (max(d) if d else None), "lod_keep_fraction": plan.keep_fraction(),
                "strands_expanded": drawn, "strands_full": full, "dom_strand_step": step}

    def _single_sample(self) -> None:
        for key in ("hdr_depth", "hdr", "hdr_resolved"):
            for o in self._targets.pop(key, ()):
                o.release()
        self.samples = 1

    def oit_stats(self) -> dict:
        """The transparency method's numbers: ``oit``, ``oit_bytes`` (its GPU memory now), ..."""
        for p in self.passes:
            if p.name == "oit":
                return p.stats()
        return {"oit": "none", "oit_bytes": 0}

    def release(self) -> None:
        """Free every GPU object (targets, passes, strands, head); safe to call twice. Also called
        when the renderer is dropped or leaves a ``with`` block."""
        if not self.released_now():
            return
        # Give the context back its framebuffer: moderngl's ctx.fbo would otherwise
        # point at one of ours once released, and break the next ctx.scope().
        if self._initial_fbo is not None and not isinstance(self._initial_fbo.mglo, moderngl.InvalidObject):
            self._initial_fbo.use()
        else:
            self.ctx.fbo = None
        self._replay.forget()
        for p in self.passes:
            p.release()
        self._drop_still_settings()
        self.scan_forms.release()
        for v in self._targets.values():
            for o in v:
                o.release()
        self._targets.clear()
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        if self._head_gpu is not None:
            for o in self._head_gpu:
                o.release()
            self._head_gpu = None
        self._release_table()
        if self.strands is not None:
            self.strands.release()
            self.strands = None
