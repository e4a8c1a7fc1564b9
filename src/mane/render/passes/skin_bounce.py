"""The skin's one-bounce light on the hair (``settings.skin_bounce``): a reflective shadow map
of the head (Dachsbacher and Stamminger 2005) gathered at the cells of a grid in light 0's space,
which every shaded hair point reads once.

Light 0's light that reaches the head's skin (shadowed by the head and by the hair's maps, as
the head pass shades it) is reflected by the Lambertian skin, and the hair around the head is
lit by it: on the curly head 0.17 of the path tracer's light in the hair pixels, red (the
skin's albedo), most on the curls beside the neck (docs/quality.md, items (7) and (10)).

    pass "skin_bounce" (after the shadow maps, before the head and the hair): the head drawn from
    light 0 (head.vert, skin_rsm.frag) into RSM_SIZE^2 texels of flux, normal and light depth,
    mipmapped; then (base.SKIN_BOUNCE_GRID) skin_bounce_grid.comp: skin_bounce.glsl's gather, SAMPLES samples
    within RADIUS, at the centre of every cell of a grid_size() grid (GRID_SIZE, 64^3, on GPUs;
    GRID_SIZE_SOFTWARE, 32^3, on CPU rasterisers) over the padded hair box's footprint in the map
    (u, v) and its light depth range, into an RGBA16F 3D texture; frame.targets["skin_rsm"]
    hair shading (hair_radiance.glsl, both rasterisers and the transparency methods): the grid's
    trilinear value at the shaded point (clamped to the grid's border outside it; base.SKIN_BOUNCE_GRID False:
    the gather at the point), times the fibre's isotropic albedo / 4 pi

The grid smooths the gather's field, which has centimetre structure near the skin (the hair's
opacity in the skin's column, the skin's nearest samples): on the curly head (fidelity scene)
at 20,000 random hair points the grid's mean absolute difference from the gather is 0.18 (64^3)
/ 0.29 (32^3) of the mean bounce (p95 0.63 / 1.20), the bounce summed over the points within
2 %; in the frame the hair pixels differ from the gather's by 2.8 % / 5.5 % on average
(docs/quality.md, item (10)). A cell centre less than a cell behind the skin of its column
(inside the head, where the gather is 0) is moved to the skin, so the hair just above the skin
is not dimmed toward the inside (32^3: the bounce summed over the hair points 0.94 -> 0.99 of
the gather's).

The hair between the skin and the shaded point: with deep opacity maps (the default) the map
keeps, per texel, the deep opacity layers averaged over its footprint, and each sample's light
is attenuated by exp(-shadow_density * (O(skin) - O(point's light depth))) of its skin's column:
the hair over the skin that the light toward a point above it crosses (the crown's fibres over
the scalp); light going sideways (the neck to the curls beside it) is not attenuated by the hair
it crosses at the point's depth, which that column does not hold. Without it mane's bounce
was 2.0x the path tracer's over the curly head's hair (2.8x at the crown), with it 1.13x.

Compiled in (the SKIN_BOUNCE define, base.bounce_defines) only where the term is on: skin_bounce > 0
and a head drawn; otherwise the hair programs are the ones they were, and the frame is bit for bit
what it was. ``gather_numpy`` is the GLSL gather's twin, ``grid_numpy`` and ``grid_lookup_numpy``
the grid's and its look-up's (tests/test_render_skin_bounce.py).
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu.capabilities import get_capabilities
from ...gpu.glsl import ProgramMemo, compute_shader, program
from ..bindings import IMG_BOUNCE_GRID, TEX_RSM_DOM, TEX_RSM_FLUX, TEX_RSM_GEOM, TEX_RSM_GRID
from . import base
from .base import (RENDER_DIR, SKIN_BOUNCE_SAMPLES as SAMPLES, Frame, Pass, bind_lighting, same_box, set_uniforms,
                   set_view, shader_path, shadow_defines, skin_bounce_active)
from .head_pass import SkinColors

RSM_SIZE = 128      # texels per side over light 0's view (the scene's bounding sphere): ~5 mm on a head
RADIUS = 0.10       # m: the gather's radius in light 0's view plane
# cells in u, v (over the hair's footprint in the map) and light depth (the hair's range along it);
# CPU rasterisers a coarser one (64^3 cells cost llvmpipe ~0.5 s a frame, 32^3 50-75 ms)
GRID_SIZE = (64, 64, 64)
GRID_SIZE_SOFTWARE = (32, 32, 32)
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def grid_size(renderer) -> tuple:
    """The grid's cells (u, v, depth) on ``renderer``'s GPU: GRID_SIZE, or GRID_SIZE_SOFTWARE on a CPU rasteriser."""
    return tuple(GRID_SIZE_SOFTWARE if get_capabilities(renderer.ctx).is_software else GRID_SIZE)


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
    light_space = True

    def __init__(self, renderer):
        super().__init__(renderer)
        self._programs = ProgramMemo()
        self.flux = self.geom = self.dom = self.depth = self.fbo = self.grid = None
        self._uniforms = None   # ((light view, settings), uniforms, the deepest mip level the gather reads)
        self._box = None        # (light view, gather's uniforms, hair box, pad, gather's and grid's uniforms)
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
                defines={**shadow_defines(ctx, s, pcf=s.head_pcf)}))
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.BLEND)
            set_view(prog, lv)
            bind_lighting(r, prog, frame)
            set_uniforms(prog, self._colors.uniforms(r))
            dom_box = max(1, int(s.shadow_map_size) // RSM_SIZE)
            set_uniforms(prog, {"u_rsm_dom_box": dom_box})
            r.draw_head(prog, cull_back=True)
        u = self.uniforms(lv)
        levels = self._uniforms[2]
        for t in (self.flux, self.geom, self.dom):
            # moderngl leaves the filter trilinear; the gather's levels are whole numbers, so that
            # reads each sample's level alone (no filter to set again every frame). Only the
            # levels the gather reads are built: each level is a pass of the raster units (H200,
            # the target frame: the pass 0.214 -> 0.151 ms with 3 levels of 7)
            t.build_mipmaps(0, levels)
        r.hdr_fbo().use()
        if base.SKIN_BOUNCE_GRID and r.strands is not None:   # no hair: nothing reads it
            u = self._grid_uniforms(lv, u) if lv is not None else u
            self._build_grid(frame, u)
        frame.targets["skin_rsm"] = (self.flux, self.geom, self.dom, u, self.grid)

    def _grid_uniforms(self, lv, gather: dict) -> dict:
        """The gather's uniforms ``gather`` and the grid's: its box (the padded hair box in light
        view ``lv``'s (u, v, depth)) and size; one dict kept while they are the same."""
        r = self.renderer
        size = grid_size(r)
        box, pad = r.hair_bbox(), r.strand_pad()
        memo = self._box
        if (memo is not None and memo[0] is lv and memo[1] is gather and same_box(memo[2], box) and memo[3] == pad
                and memo[4]["u_grid_size"] == size):
            return memo[4]
        b = grid_box(lv.view_proj, lv.eye, lv.forward, box[0] - pad, box[1] + pad)
        out = {**gather, "u_bounce_grid_lo": tuple(map(float, b[0])),
               "u_bounce_grid_inv": tuple(map(float, 1.0 / (b[1] - b[0]))), "u_grid_size": size}
        self._box = (lv, gather, box, pad, out)
        return out

    def _build_grid(self, frame: Frame, u: dict) -> None:
        """skin_bounce_grid.comp: the gather at every cell of the grid (grid_size)."""
        r, ctx = self.renderer, self.ctx
        size = grid_size(r)
        if self.grid is not None and self.grid.size != size:
            self.grid.release()
            self.grid = None
        if self.grid is None:
            self.grid = ctx.texture3d(size, 4, dtype="f2")
            self.grid.repeat_x = self.grid.repeat_y = self.grid.repeat_z = False
        if "u_bounce_grid_lo" not in u:   # no light: nothing to gather
            self.grid.write(np.zeros(size[::-1] + (4,), np.float16).tobytes())
            return
        s = r.settings
        cs = self._programs.get("grid", (s,), lambda: compute_shader(
            ctx, shader_path("skin_bounce_grid.comp"),
            {**shadow_defines(ctx, s), "SKIN_BOUNCE_SAMPLES": SAMPLES}, include_dirs=[RENDER_DIR]))
        bind_lighting(r, cs, frame)
        self.flux.use(TEX_RSM_FLUX)
        self.geom.use(TEX_RSM_GEOM)
        self.dom.use(TEX_RSM_DOM)
        set_uniforms(cs, u)
        self.grid.bind_to_image(IMG_BOUNCE_GRID, read=False, write=True)
        nx, ny, nz = size
        cs.run(-(-nx // 4), -(-ny // 4), -(-nz // 4))
        ctx.memory_barrier()

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
             "u_skin_bounce": float(r.settings.skin_bounce), "u_bounce_grid": TEX_RSM_GRID}
        self._uniforms = ((lv, r.settings), u, int(table[:, 3].max()))
        return u

    def release(self) -> None:
        for o in (self.fbo, self.flux, self.geom, self.dom, self.depth, self.grid):
            if o is not None:
                o.release()
        self.flux = self.geom = self.dom = self.depth = self.fbo = self.grid = None


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


def grid_box(view_proj, eye, fwd, lo, hi) -> np.ndarray:
    """(2, 3): the grid's corners in (u, v, light depth): the map coordinates and light depths
    of the world box ``lo``..``hi`` (the padded hair box), u and v within the map."""
    vp = np.asarray(view_proj, np.float64)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], np.float64)
    c = np.c_[corners, np.ones(8)] @ vp.T
    uv = np.clip(c[:, :2] / c[:, 3:] * 0.5 + 0.5, 0.0, 1.0)
    z = (corners - np.asarray(eye, np.float64)) @ np.asarray(fwd, np.float64)
    box = np.array([[*uv.min(axis=0), z.min()], [*uv.max(axis=0), z.max()]])
    box[1] = np.maximum(box[1], box[0] + 1e-6)
    return box


def grid_centres(box, size=GRID_SIZE) -> np.ndarray:
    """(nz, ny, nx, 3): the (u, v, light depth) of every cell's centre, cell (i, j, k) at
    box[0] + ((i, j, k) + 1/2) / size * (box[1] - box[0])."""
    nx, ny, nz = size
    box = np.asarray(box, np.float64)
    axes = [box[0, a] + (np.arange(n) + 0.5) / n * (box[1, a] - box[0, a]) for a, n in enumerate((nx, ny, nz))]
    z, v, u = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([u, v, z], axis=-1)


def grid_numpy(box, size, flux_levels, geom_levels, samples, view_proj, eye, fwd, **occlusion) -> np.ndarray:
    """skin_bounce_grid.comp's twin: (nz, ny, nx, 3) gather_numpy at every cell's centre (the
    point of the map's view at its (u, v, light depth); a centre less than a cell behind the skin
    of its column moved to the skin); ``occlusion``: gather_numpy's dom_levels, layers and density."""
    c = grid_centres(box, size).reshape(-1, 3)
    inv = np.linalg.inv(np.asarray(view_proj, np.float64))
    eye, fwd = np.asarray(eye, np.float64), np.asarray(fwd, np.float64)
    f = bilinear(flux_levels[0], c[:, :2])
    zs = np.where(f[:, 3] > 0.5, bilinear(geom_levels[0], c[:, :2])[:, 3] / np.maximum(f[:, 3], 1e-30), np.inf)
    dz = (box[1][2] - box[0][2]) / size[2]
    z = np.where((c[:, 2] > zs) & (c[:, 2] < zs + dz), zs, c[:, 2])
    x = rsm_point(c[:, :2], z, inv, eye, fwd)
    nx, ny, nz = size
    return gather_numpy(x, flux_levels, geom_levels, samples, view_proj, eye, fwd, **occlusion).reshape(nz, ny, nx, 3)


def trilinear(grid: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(nz, ny, nx, C) grid sampled at texture coordinates t (M, 3) as GL_LINEAR with
    clamp-to-edge does (cell (i, j, k)'s centre at ((i, j, k) + 1/2) / size)."""
    nz, ny, nx = grid.shape[:3]
    f = t * np.array([nx, ny, nz]) - 0.5
    f0 = np.floor(f)
    w = f - f0
    out = 0.0
    for dk in (0, 1):
        for dj in (0, 1):
            for di in (0, 1):
                i = np.clip(f0[:, 0] + di, 0, nx - 1).astype(np.int64)
                j = np.clip(f0[:, 1] + dj, 0, ny - 1).astype(np.int64)
                k = np.clip(f0[:, 2] + dk, 0, nz - 1).astype(np.int64)
                wt = ((w[:, 0] if di else 1 - w[:, 0]) * (w[:, 1] if dj else 1 - w[:, 1])
                      * (w[:, 2] if dk else 1 - w[:, 2]))
                out = out + wt[:, None] * grid[k, j, i]
    return out


def grid_lookup_numpy(x, grid, box, view_proj, eye, fwd) -> np.ndarray:
    """skin_bounce.glsl's skin_bounce_grid at points x (M, 3): the grid's trilinear value at
    each point's (u, v, light depth), clamped to the grid's border cells outside it."""
    x = np.atleast_2d(np.asarray(x, np.float64))
    c = np.c_[x, np.ones(len(x))] @ np.asarray(view_proj, np.float64).T
    uvz = np.c_[c[:, :2] / c[:, 3:] * 0.5 + 0.5, (x - np.asarray(eye, np.float64)) @ np.asarray(fwd, np.float64)]
    box = np.asarray(box, np.float64)
    return trilinear(np.asarray(grid, np.float64), (uvz - box[0]) / (box[1] - box[0]))
