"""The viewer's gizmos, drawn into the renderer's HDR target before the resolve: the collision
sphere and the lights' handles (shaders beside this file: gizmo_*.vert/.frag)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..gpu.glsl import program
from ..gpu.uniforms import write_uniform
from .passes.base import Pass

HERE = Path(__file__).resolve().parent


def _sphere_mesh(lat: int, lon: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit sphere: (vertices (N, 3) float32, triangle indices (M,) int32)."""
    th = np.linspace(0, np.pi, lat + 1)
    ph = np.linspace(0, 2 * np.pi, lon + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    pts = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(lat), np.arange(lon), indexing="ij")
    a, b = (i * (lon + 1) + j).ravel(), ((i + 1) * (lon + 1) + j).ravel()
    idx = np.stack([a, b, a + 1, a + 1, b, b + 1], 1).ravel()
    return pts.astype(np.float32), idx.astype(np.int32)


class GizmoPass(Pass):
    """Draws the collision sphere (see-through, depth tested) and the lights' handles (small
    balls in each light's colour, with a line from the scene's centre for directional lights;
    faint where the scene hides them) into the renderer's HDR target: 5 draws in all."""

    name = "gizmos"
    reads = ("hdr",)
    writes = ("hdr",)

    MAX_BALLS = 3 * 8      # 3 per light (the ring's two and the handle)
    MAX_LINES = 8

    def __init__(self, renderer, viewer):
        super().__init__(renderer)
        self.viewer = viewer
        self._prog = self._handle_prog = self._line_prog = None
        self._vao = self._handle_vao = self._line_vao = None
        self._balls = self._lines = None
        self._buffers = ()

    def enabled(self, frame) -> bool:
        v = self.viewer
        return (v.sphere is not None and v.show_sphere) or (v.show_light_handles and bool(v.lights))

    def _build(self):
        ctx = self.ctx
        # uncached: this pass owns (and releases) its programs
        self._prog = program(ctx, vertex=HERE / "gizmo_sphere.vert", fragment=HERE / "gizmo_sphere.frag", cache=False)
        # the handles: one instanced draw of small balls, (centre, radius) and (rgb, alpha) per ball
        self._handle_prog = program(ctx, vertex=HERE / "gizmo_handle.vert", fragment=HERE / "gizmo_handle.frag",
                                    cache=False)
        self._line_prog = program(ctx, vertex=HERE / "gizmo_line.vert", fragment=HERE / "gizmo_line.frag", cache=False)
        pts, idx = _sphere_mesh(16, 32)
        vbo, ibo = ctx.buffer(pts.tobytes()), ctx.buffer(idx.tobytes())
        self._vao = ctx.vertex_array(self._prog, [(vbo, "3f", "in_position")], index_buffer=ibo, index_element_size=4)
        small, small_idx = _sphere_mesh(8, 12)   # a handle is a few pixels across
        hvbo, hibo = ctx.buffer(small.tobytes()), ctx.buffer(small_idx.tobytes())
        self._balls = ctx.buffer(reserve=self.MAX_BALLS * 32, dynamic=True)
        self._handle_vao = ctx.vertex_array(self._handle_prog, [(hvbo, "3f", "in_position"),
                                                                (self._balls, "4f 4f/i", "in_ball", "in_rgba")],
                                            index_buffer=hibo, index_element_size=4)
        self._lines = ctx.buffer(reserve=self.MAX_LINES * 2 * 28, dynamic=True)
        self._line_vao = ctx.vertex_array(self._line_prog, [(self._lines, "3f 4f", "in_position", "in_rgba")])
        self._buffers = (vbo, ibo, hvbo, hibo, self._balls, self._lines)

    def run(self, frame) -> None:
        if self._prog is None:
            self._build()
        ctx, v = self.ctx, self.viewer
        fbo = self.renderer.hdr_fbo()
        fbo.use()
        view_proj = np.asarray(frame.view.view_proj, np.float32).T.copy().tobytes()
        eye = tuple(float(x) for x in frame.view.eye)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
        fbo.depth_mask = False     # see-through: the gizmos write no depth
        try:
            if v.sphere is not None and v.show_sphere:
                ctx.enable(ctx.DEPTH_TEST)
                p = self._prog
                write_uniform(p["u_view_proj"], view_proj)
                if "u_eye" in p:
                    write_uniform(p["u_eye"], eye)
                hot = v.dragging_sphere or v.hover_sphere
                c = v.sphere.transform[:3, 3]
                write_uniform(p["u_sphere"], (float(c[0]), float(c[1]), float(c[2]), float(v.sphere.radius)))
                write_uniform(p["u_color"], (0.35, 0.75, 1.6) if hot else (0.25, 0.45, 0.9))
                write_uniform(p["u_alpha"], 0.25 if hot else 0.15)
                self._vao.render()
            if v.show_light_handles and v.lights:
                self._handles(view_proj, eye)
        finally:
            fbo.depth_mask = True
            ctx.disable(ctx.BLEND)
            ctx.enable(ctx.DEPTH_TEST)

    def handle_geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """(balls (B, 8): centre, radius, rgb, alpha in drawing order; line vertices (L, 7):
        position, rgba) for the viewer's lights."""
        v = self.viewer
        balls, lines = [], []
        for i, light in enumerate(v.lights[: self.MAX_LINES]):
            pos = v.light_handle_position(i)
            hot = i in (v.hover_light, v.dragging_light)
            selected = i == v.selected_light
            rgb = handle_color(light)
            if not light.is_point:     # the direction: a line from the scene's centre
                a = 0.6 if (hot or selected) else 0.3
                lines += [[*v.light_centre, *rgb, a], [*pos, *rgb, a]]
            r = v.light_handle_radius(pos)
            if selected or hot:        # a white ring around the selected or grabbed one
                balls.append([*pos, r * 1.45, 1.2, 1.2, 1.2, 0.9 if hot else 0.6])
                balls.append([*pos, r * 1.2, 0.02, 0.02, 0.02, 1.0])
            balls.append([*pos, r, *rgb, 1.0])
        return (np.asarray(balls, np.float32).reshape(-1, 8)[: self.MAX_BALLS],
                np.asarray(lines, np.float32).reshape(-1, 7))

    def _handles(self, view_proj, eye) -> None:
        """The lights' handles: where the scene hides them, faint (they stay visible and
        pickable), else bright."""
        ctx = self.ctx
        balls, lines = self.handle_geometry()
        if len(balls):
            self._balls.write(balls.tobytes())
        if len(lines):
            self._lines.write(lines.tobytes())
        hp, lp = self._handle_prog, self._line_prog
        write_uniform(hp["u_view_proj"], view_proj)
        write_uniform(lp["u_view_proj"], view_proj)
        if "u_eye" in hp:
            write_uniform(hp["u_eye"], eye)
        ctx.enable(ctx.DEPTH_TEST)
        try:
            for depth_func, fade in ((">=", 0.35), ("<", 1.0)):
                ctx.depth_func = depth_func
                write_uniform(hp["u_fade"], fade)
                write_uniform(lp["u_fade"], fade)
                if len(lines):
                    self._line_vao.render(ctx.LINES, vertices=len(lines))
                if len(balls):
                    self._handle_vao.render(instances=len(balls))
        finally:
            ctx.depth_func = "<"

    def release(self) -> None:
        for o in (self._vao, self._handle_vao, self._line_vao, *self._buffers, self._prog, self._handle_prog,
                  self._line_prog):
            if o is not None:
                o.release()
        self._prog = self._handle_prog = self._line_prog = None
        self._vao = self._handle_vao = self._line_vao = None
        self._balls = self._lines = None
        self._buffers = ()


def handle_color(light) -> tuple[float, float, float]:
    """A light's handle colour: its colour, brightest channel at 1.6 (HDR, before tone mapping)."""
    c = np.maximum(np.asarray(light.color, float), 0.0)
    m = float(c.max())
    c = c / m if m > 0 else np.ones(3)
    return tuple(float(x) * 1.6 for x in c)
