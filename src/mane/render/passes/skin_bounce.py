"""The skin's one-bounce light on the hair (``settings.skin_bounce``): a reflective shadow map
of the head (Dachsbacher and Stamminger 2005) gathered by every shaded hair point.

Light 0's light that reaches the head's skin (shadowed by the head and by the hair's maps, as
the head pass shades it) is reflected by the Lambertian skin, and the hair around the head is
lit by it: on the curly head 0.17 of the path tracer's light in the hair pixels, red (the
skin's albedo), most on the curls beside the neck (docs/quality.md, items (7) and (10)).

    pass "skin_bounce" (after the shadow maps, before the head and the hair): the head drawn from
    light 0 (head.vert, skin_rsm.frag) into RSM_SIZE^2 texels of flux, normal and light depth,
    mipmapped; frame.targets["skin_rsm"]
    hair shading (hair_radiance.glsl, both rasterisers and the transparency methods): skin_bounce.glsl's
    gather, SAMPLES samples within RADIUS of the shaded point, times the fibre's isotropic albedo
    / 4 pi (on CPU rasterisers the raster units' pass gathers at the strand points:
    base.BOUNCE_AT_POINTS)

The hair between the skin and the shaded point: with deep opacity maps (the default) the map
keeps, per texel, the deep opacity layers averaged over its footprint, and each sample's light
is attenuated by exp(-shadow_density * (O(skin) - O(point's light depth))) of its skin's column:
the hair over the skin that the light toward a point above it crosses (the crown's fibres over
the scalp); light going sideways (the neck to the curls beside it) is not attenuated by the hair
it crosses at the point's depth, which that column does not hold. Without it mane's bounce
was 2.0x the path tracer's over the curly head's hair (2.8x at the crown), with it 1.13x.

Compiled in (the SKIN_BOUNCE define, base.bounce_defines) only where the term is on: skin_bounce > 0
and a head drawn; otherwise the hair programs are the ones they were, and the frame is bit for bit
what it was. ``gather_numpy`` is the GLSL gather's twin (tests/test_render_skin_bounce.py).
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu.glsl import ProgramMemo, program
from ..bindings import TEX_RSM_DOM, TEX_RSM_FLUX, TEX_RSM_GEOM
from .base import (SKIN_BOUNCE_SAMPLES as SAMPLES, Frame, Pass, bind_lighting, set_uniforms, set_view, shader_path,
                   shadow_defines, skin_bounce_active)
from .head_pass import SkinColors

RSM_SIZE = 128      # texels per side over light 0's view (the scene's bounding sphere): ~5 mm on a head
RADIUS = 0.10       # m: the gather's radius in light 0's view plane
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def mip_levels(size: int = RSM_SIZE) -> int:
    return int(math.log2(size)) + 1


def sample_table(view_width: float, *, samples: int = SAMPLES, radius: float = RADIUS,
                 size: int = RSM_SIZE) -> np.ndarray:
    """(samples, 4) float32: each gather sample's (du, dv) offset in the map's uv, the area
    A_k (m^2 of the light's view) it stands for and its mip level. Sample k sits at
    r_k = radius (k + 1/2) / samples on a golden-angle spiral and stands for the annulus
    between radius k / samples and (k + 1) / samples shared among the samples:
    A_k = pi radius^2 (2k + 1) / samples^2 (the areas sum to the disc's); its level's texel is
    the nearest power of two to sqrt(A_k). ``view_width``: the light view's width (m)."""
    k = np.arange(samples, dtype=np.float64)
    r = radius * (k + 0.5) / samples
    a = k * GOLDEN_ANGLE
    area = math.pi * radius * radius * (2.0 * k + 1.0) / (samples * samples)
    texel = view_width / size
    lod = np.clip(np.round(np.log2(np.sqrt(area) / texel)), 0, mip_levels(size) - 1)
    return np.stack([r * np.cos(a) / view_width, r * np.sin(a) / view_width, area, lod], axis=1).astype(np.float32)


def view_width(renderer, lv) -> float:
    """The world width (m) of light view ``lv`` (at the scene's centre for a point light)."""
    n = int(renderer.settings.shadow_map_size)
    if lv.ortho:
        return float(lv.pixel_size) * n
    return float(lv.pixel_size) * n * float(np.linalg.norm(renderer.scene_center() - lv.eye))


class SkinBouncePass(Pass):
    name = "skin_bounce"
    reads = ("head", "shadow_map", "dom")
    writes = ("skin_rsm",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self.flux = self.geom = self.dom = self.depth = self.fbo = None
        self._uniforms = None   # ((light view, settings), uniforms)
        self._colors = SkinColors()

    def enabled(self, frame: Frame) -> bool:
        return skin_bounce_active(self.renderer)

    def _target(self):
        if self.fbo is None:
            ctx, n = self.ctx, RSM_SIZE
            self.flux = ctx.texture((n, n), 4, dtype="f4")
            self.geom = ctx.texture((n, n), 4, dtype="f4")
            self.dom = ctx.texture((n, n), 4, dtype="f4")
            for t in (self.flux, self.geom, self.dom):
                t.repeat_x = t.repeat_y = False
            self.depth = ctx.depth_renderbuffer((n, n))
            self.fbo = ctx.framebuffer([self.flux, self.geom, self.dom], self.depth)
        return self.fbo

    def run(self, frame: Frame) -> None:
        r, ctx = self.renderer, self.ctx
        s = r.settings
        fbo = self._target()
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        lv = frame.light_view if frame.light_view is not None else (r.light_view(frame.lights[0]) if frame.lights else None)
        if lv is not None:
            prog = self._programs.get("rsm", (s,), lambda: program(
                ctx, vertex=shader_path("head.vert"), fragment=shader_path("skin_rsm.frag"),
                defines={**shadow_defines(s, pcf=s.head_pcf)}))
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.BLEND)
            set_view(prog, lv)
            bind_lighting(r, prog, frame)
            set_uniforms(prog, self._colors.uniforms(r))
            dom_box = max(1, int(s.shadow_map_size) // RSM_SIZE)
            set_uniforms(prog, {"u_rsm_dom_box": dom_box})
            r.draw_head(prog, cull_back=True)
        levels = mip_levels() - 1
        for t in (self.flux, self.geom, self.dom):
            # moderngl leaves the filter trilinear; the gather's levels are whole numbers, so that
            # reads each sample's level alone (no filter to set again every frame)
            t.build_mipmaps(0, levels)
        r.hdr_fbo().use()
        frame.targets["skin_rsm"] = (self.flux, self.geom, self.dom, self.uniforms(lv))

    def uniforms(self, lv) -> dict:
        """The gather's uniforms for light view ``lv`` (kept while it and the settings are the same)."""
        r = self.renderer
        memo = self._uniforms
        if memo is not None and memo[0][0] is lv and memo[0][1] is r.settings:
            return memo[1]
        if lv is None:   # no light: the map is empty, the gather adds nothing
            vp, eye, fwd, width = np.eye(4), np.zeros(3), np.array([0.0, 0.0, 1.0]), 1.0
        else:
            vp, eye, fwd, width = lv.view_proj, lv.eye, lv.forward, view_width(r, lv)
        table = sample_table(width)
        u = {"u_rsm_flux": TEX_RSM_FLUX, "u_rsm_geom": TEX_RSM_GEOM, "u_rsm_dom": TEX_RSM_DOM,
             "u_rsm_view_proj": np.asarray(vp, np.float64), "u_rsm_inv_view_proj": np.linalg.inv(vp),
             "u_rsm_eye": tuple(map(float, eye)), "u_rsm_dir": tuple(map(float, fwd)),
             "u_rsm_samples": [tuple(map(float, row)) for row in table],
             "u_skin_bounce": float(r.settings.skin_bounce)}
        self._uniforms = ((lv, r.settings), u)
        return u

    def release(self) -> None:
        for o in (self.fbo, self.flux, self.geom, self.dom, self.depth):
            if o is not None:
                o.release()
        self.flux = self.geom = self.dom = self.depth = self.fbo = None


# ---------------------------------------------------------------- the NumPy twin
def bilinear(level: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(H, W, C) texture level sampled at uv (M, 2) as GL_LINEAR with clamp-to-edge does:
    texel (i, j)'s centre at ((i + 1/2) / W, (j + 1/2) / H), rows from v = 0."""
    h, w = level.shape[:2]
    x = uv[:, 0] * w - 0.5
    y = uv[:, 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    def at(i, j):
        return level[np.clip(j, 0, h - 1).astype(np.int64), np.clip(i, 0, w - 1).astype(np.int64)]
    return ((1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0)
            + (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1))


def mipmaps(level0: np.ndarray) -> list:
    """The mip chain of a (n, n, C) power-of-two level by 2 x 2 means (what GL builds)."""
    out = [np.asarray(level0, np.float64)]
    while out[-1].shape[0] > 1:
        a = out[-1]
        out.append(0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2]))
    return out


def rsm_point(uv: np.ndarray, z: np.ndarray, inv_vp: np.ndarray, eye, fwd) -> np.ndarray:
    ndc = uv * 2.0 - 1.0
    m = len(uv)
    a = np.c_[ndc, -np.ones(m), np.ones(m)] @ inv_vp.T
    b = np.c_[ndc, np.ones(m), np.ones(m)] @ inv_vp.T
    A, B = a[:, :3] / a[:, 3:], b[:, :3] / b[:, 3:]
    za, zb = (A - eye) @ fwd, (B - eye) @ fwd
    return A + (B - A) * ((z - za) / (zb - za))[:, None]


def dom_opacity(t: np.ndarray, z: np.ndarray, layers) -> np.ndarray:
    """lighting.glsl's dom_opacity: the opacity in front of depth z of deep opacity texels t (M, 4)."""
    d1, d2, d3 = layers
    dz = z - t[:, 3]
    r, g, b = t[:, 0], t[:, 1], t[:, 2]
    return np.where(dz <= 0, 0.0, np.where(dz < d1, r * dz / d1, np.where(
        dz < d2, r + (g - r) * (dz - d1) / (d2 - d1), np.where(dz < d3, g + (b - g) * (dz - d2) / (d3 - d2), b))))


def gather_numpy(x, flux_levels, geom_levels, samples, view_proj, eye, fwd, dom_levels=None, layers=None,
                 density: float = 0.0) -> np.ndarray:
    """skin_bounce.glsl's skin_bounce_fluence at points x (M, 3): (M, 3) fluence. The levels are
    the maps' mip chains ((n, n, 4) arrays, row 0 at v = 0), ``samples`` sample_table's rows;
    ``dom_levels`` (with the deep opacity ``layers`` ends and ``density``): the hair's opacity in
    the skin's column (SHADOWS 2), None: no hair."""
    x = np.atleast_2d(np.asarray(x, np.float64))
    vp = np.asarray(view_proj, np.float64)
    inv = np.linalg.inv(vp)
    eye, fwd = np.asarray(eye, np.float64), np.asarray(fwd, np.float64)
    c = np.c_[x, np.ones(len(x))] @ vp.T
    uv0 = c[:, :2] / c[:, 3:] * 0.5 + 0.5
    phi = np.zeros((len(x), 3))
    for du, dv, area, lod in np.asarray(samples, np.float64):
        uv = uv0 + (du, dv)
        f = bilinear(flux_levels[int(lod)], uv)
        g = bilinear(geom_levels[int(lod)], uv)
        ok = f[:, 3] >= 1e-4
        cov = np.where(ok, f[:, 3], 1.0)
        p = rsm_point(uv, g[:, 3] / cov, inv, eye, fwd)
        w = x - p
        d2 = np.maximum(np.sum(w * w, axis=1), 1e-12)
        tr = 1.0
        if dom_levels is not None:
            o = bilinear(dom_levels[int(lod)], uv) / cov[:, None]
            zs = g[:, 3] / cov
            zx = (x - eye) @ fwd
            tr = np.exp(-density * np.maximum(dom_opacity(o, zs, layers) - dom_opacity(o, np.minimum(zx, zs), layers), 0.0))
        d = np.sqrt(d2)
        e = np.maximum(np.sum(g[:, :3] / cov[:, None] * w, axis=1), 0.0) / d
        a2 = area / math.pi
        s = np.sqrt(d2 + a2)
        phi += np.where(ok[:, None], f[:, :3] * (2.0 * tr * e * a2 / (s * (s + d)))[:, None], 0.0)
    return phi
