"""settings.skin_bounce: the light the head's skin reflects onto the hair, a reflective shadow
map of the head gathered at the cells of a grid in the light's space that every shaded hair point
reads (mane/render/passes/skin_bounce.py, skin_bounce.glsl, skin_bounce_grid.comp). The GLSL
gather and grid against their NumPy twins, the gather's twin against the analytic fluence of a
lit Lambertian plane, the grid against the gather at a scene's hair points and in its frames,
and the renderer: off and without a head nothing changes, with a head the hair beside the lit
skin gains warm light."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mane.bench.fidelity import realtime_linear
from mane.groom import Groom
from mane.render import Camera, Light, Renderer, RenderSettings
from mane.render.camera import look_at, orthographic
from mane.render.passes import skin_bounce as sb

# an orthographic light 0 looking down -y at the plane y = 0, 0.5 m wide
VIEW = orthographic(0.25, 0.25, 0.1, 2.0) @ look_at(np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 0.0]),
                                                    np.array([0.0, 0.0, -1.0]))
EYE, FWD, WIDTH = np.array([0.0, 1.0, 0.0]), np.array([0.0, -1.0, 0.0]), 0.5


def _plane_maps(n, flux=(1.0, 0.5, 0.25), bumpy=False, seed=0):
    """(flux, geom, dom) level-0 maps of the plane y = 0 seen from EYE: depth 1 m; ``bumpy``: a
    smooth varying flux, normal, depth, coverage and hair above it."""
    rng = np.random.default_rng(seed)
    u = (np.arange(n) + 0.5) / n
    U, V = np.meshgrid(u, u)
    f = np.zeros((n, n, 4), np.float32)
    g = np.zeros((n, n, 4), np.float32)
    d = np.zeros((n, n, 4), np.float32)
    f[..., :3] = flux
    f[..., 3] = 1.0
    g[..., 1] = 1.0
    g[..., 3] = 1.0
    d[..., 3] = 0.9   # hair from 0.1 m above the plane
    if bumpy:
        f[..., :3] *= (1.0 + 0.5 * np.sin(7 * U + 3 * V))[..., None] * rng.uniform(0.5, 1.0, (n, n, 1))
        cov = np.clip(1.2 - 2.5 * np.hypot(U - 0.5, V - 0.5), 0.0, 1.0) * (rng.uniform(size=(n, n)) > 0.1)
        nx, nz = 0.3 * np.sin(5 * V), 0.3 * np.cos(4 * U)
        nrm = np.stack([nx, np.ones_like(nx), nz], -1)
        nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
        g[..., :3] = nrm
        g[..., 3] = 1.0 + 0.05 * np.sin(6 * U) * np.cos(5 * V)
        d[..., :3] = np.stack([0.2 * U, 0.5 * U + 0.2, 1.0 + V], -1)
        for a in (f, g, d):
            a *= cov[..., None]
        f[..., 3] = cov
    return f, g, d


def _probe_source(tmp_path, function: str):
    """A kernel writing ``function``(point) (skin_bounce.glsl) for each point at binding 0."""
    path = tmp_path / f"{function}_probe.comp"
    grid = "#define SKIN_BOUNCE_GRID 1\n" if function == "skin_bounce_grid" else ""
    path.write_text(f"""#version 430
{grid}#include "common.glsl"
#include "lighting.glsl"
#include "skin_bounce.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Points {{ vec4 pts[]; }};
layout(std430, binding = 1) writeonly buffer Out {{ vec4 outv[]; }};
uniform int u_count;
void main() {{
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(u_count)) return;
    outv[i] = vec4({function}(pts[i].xyz), 0.0);
}}
""")
    return path

def _filter_tolerance(gl, exact: float, fixed: float) -> float:
    """The twins' tolerance for a sum of bilinear look-ups: ``exact`` where the GL filters in
    floating point (llvmpipe), ``fixed`` on a GPU, whose texture units keep a filter weight in
    fixed point (8 fractional bits on NVIDIA's: a look-up between texels a and b off by up to
    |a - b| / 512; the H200's gather 0.6 % off the exact twin at most)."""
    from mane.gpu.capabilities import get_capabilities

    return exact if get_capabilities(gl).is_software else fixed


def _snap_undecided(box, size, levels, margin_cover=0.02, margin_cell=0.05):
    """(nz, ny, nx): cells whose move to the skin (skin_bounce_grid.comp: a centre less than a cell
    behind the skin of its column) hangs on a threshold the GPU's fixed-point filter can tip:
    the column's coverage within ``margin_cover`` of 1/2, or the centre within ``margin_cell`` of
    a cell of either end of the window. Either choice is the shader's; the two differ by up to
    the skin's fluence against the head's inside."""
    c = sb.grid_centres(box, size).reshape(-1, 3)
    f = sb.bilinear(levels[0][0], c[:, :2])[:, 3]
    zs = sb.bilinear(levels[1][0], c[:, :2])[:, 3] / np.maximum(f, 1e-30)
    dz = (box[1][2] - box[0][2]) / size[2]
    m = margin_cell * dz
    near = (np.abs(f - 0.5) < margin_cover) | ((f > 0.5) & ((np.abs(c[:, 2] - zs) < m) | (np.abs(c[:, 2] - zs - dz) < m)))
    return near.reshape(size[2], size[1], size[0])


def test_plane_fluence_approaches_the_analytic_form_factor():
    """A Lambertian plane reflecting B per unit area (radiance B / pi) gives a point at height h
    the fluence 2 B (1 - h / sqrt(h^2 + R^2)) from the disc of radius R under it (the emitter's
    cosine over d^2, no receiver cosine): the gather approaches it as its samples grow (the
    area-regularised 1/d^2 and the mip levels' are the only approximations)."""
    n = 256
    f, g, _ = _plane_maps(n)
    levels_f, levels_g = sb.mipmaps(f), sb.mipmaps(g)
    errors = {}
    for h in (0.01, 0.03, 0.1):
        exact = 2.0 * (1.0 - h / math.hypot(h, sb.RADIUS))
        for samples in (16, 64, 256):
            table = sb.sample_table(WIDTH, samples=samples, size=n)
            phi = sb.gather_numpy([[0.01, h, -0.02]], levels_f, levels_g, table, VIEW, EYE, FWD)[0]
            assert np.allclose(phi / phi[0], (1.0, 0.5, 0.25), rtol=1e-9)
            errors[(h, samples)] = phi[0] / exact - 1.0
    for h in (0.01, 0.03, 0.1):
        assert abs(errors[(h, 256)]) < 0.025, errors
        assert abs(errors[(h, 256)]) < abs(errors[(h, 64)]) < abs(errors[(h, 16)]), errors
    # the default 16 samples: the quadrature's bias, low (each sample a disc around its point)
    assert -0.12 < errors[(0.03, 16)] < 0 and -0.04 < errors[(0.1, 16)] < 0, errors
    # infinite plane: 2 B as R grows (the fluence of a hemisphere of radiance B / pi)
    table = sb.sample_table(WIDTH, samples=256, radius=0.24, size=n)
    phi = sb.gather_numpy([[0.0, 0.01, 0.0]], levels_f, levels_g, table, VIEW, EYE, FWD)[0, 0]
    assert abs(phi / (2.0 * (1.0 - 0.01 / math.hypot(0.01, 0.24))) - 1.0) < 0.05, phi   # 1.917: 0.96 of 2 B


def test_plane_behind_hair_is_attenuated_by_the_columns_opacity():
    """With deep opacity layers in the skin's column, a point above the hair gets the plane's
    light through all of it, a point below the hair (between it and the skin) through none."""
    n = 64
    f, g, d = _plane_maps(n)
    d[..., :3] = (0.2, 0.4, 1.0)   # O1..O3 after z0 = 0.9 (0.1 m above the plane)
    levels = [sb.mipmaps(a) for a in (f, g, d)]
    table = sb.sample_table(WIDTH, size=n)
    layers, density = (0.01, 0.03, 0.08), 3.0   # the skin 0.1 m past z0: behind all of it
    def phi(h):
        kw = dict(dom_levels=levels[2], layers=layers, density=density)
        return (sb.gather_numpy([[0.0, h, 0.0]], levels[0], levels[1], table, VIEW, EYE, FWD, **kw)[0, 0],
                sb.gather_numpy([[0.0, h, 0.0]], levels[0], levels[1], table, VIEW, EYE, FWD)[0, 0])
    above, above_bare = phi(0.15)
    below, below_bare = phi(0.05)
    assert above == pytest.approx(above_bare * math.exp(-density * 1.0), rel=1e-6)
    # 0.05 m above the plane: 0.05 m past z0, in the third layer: O = 0.4 + 0.6 * 0.02 / 0.05
    o = 0.4 + 0.6 * (0.05 - 0.03) / 0.05
    assert below == pytest.approx(below_bare * math.exp(-density * (1.0 - o)), rel=1e-6)


@pytest.mark.gpu
def test_glsl_gather_matches_numpy(gl, tmp_path):
    from mane.gpu.glsl import compute_shader
    from mane.render.bindings import TABLE, TEX_RSM_DOM, TEX_RSM_FLUX, TEX_RSM_GEOM
    from mane.render.passes.base import RENDER_DIR, HERE, set_uniforms

    n = 64
    maps = _plane_maps(n, bumpy=True)
    texs = []
    for a in maps:
        t = gl.texture((n, n), 4, data=np.ascontiguousarray(a, np.float32).tobytes(), dtype="f4")
        t.repeat_x = t.repeat_y = False
        t.build_mipmaps(0, sb.mip_levels(n) - 1)   # trilinear, as the pass leaves its maps
        texs.append(t)
    levels = [[np.frombuffer(t.read(level=k), np.float32).reshape(n >> k, n >> k, 4).astype(np.float64)
               for k in range(sb.mip_levels(n))] for t in texs]
    src = _probe_source(tmp_path, "skin_bounce_fluence")
    cs = compute_shader(gl, src, {**TABLE, "SHADOWS": 2, "PCF": 1, "SKIN_BOUNCE_SAMPLES": sb.SAMPLES},
                        include_dirs=[HERE, RENDER_DIR])
    rng = np.random.default_rng(1)
    pts = np.c_[rng.uniform(-0.2, 0.2, 400), rng.uniform(0.005, 0.3, 400), rng.uniform(-0.2, 0.2, 400)]
    table = sb.sample_table(WIDTH, size=n)
    layers, density = (0.01, 0.03, 0.2), 3.0
    set_uniforms(cs, {"u_rsm_view_proj": VIEW, "u_rsm_inv_view_proj": np.linalg.inv(VIEW), "u_rsm_eye": tuple(EYE),
                      "u_rsm_dir": tuple(FWD), "u_rsm_samples": [tuple(map(float, r)) for r in table],
                      "u_rsm_flux": TEX_RSM_FLUX, "u_rsm_geom": TEX_RSM_GEOM, "u_rsm_dom": TEX_RSM_DOM,
                      "u_dom_layers": layers, "u_shadow_density": density, "u_count": len(pts)})
    for t, unit in zip(texs, (TEX_RSM_FLUX, TEX_RSM_GEOM, TEX_RSM_DOM)):
        t.use(unit)
    pbuf = gl.buffer(np.c_[pts, np.ones(len(pts))].astype(np.float32).tobytes())
    obuf = gl.buffer(reserve=16 * len(pts))
    pbuf.bind_to_storage_buffer(0)
    obuf.bind_to_storage_buffer(1)
    cs.run(math.ceil(len(pts) / 64))
    gl.finish()
    got = np.frombuffer(obuf.read(), np.float32).reshape(-1, 4)[:, :3]
    want = sb.gather_numpy(pts.astype(np.float32).astype(np.float64), *levels[:2], table, VIEW, EYE, FWD,
                           dom_levels=levels[2], layers=layers, density=density)
    for o in (pbuf, obuf, *texs):
        o.release()
    assert want.max() > 0.1 and np.count_nonzero(want[:, 0] > 1e-3) > 300
    scale = np.maximum(np.abs(want), 1e-3 * want.max())
    assert np.max(np.abs(got - want) / scale) < _filter_tolerance(gl, 2e-3, 1e-2), np.max(np.abs(got - want) / scale)


# ---------------------------------------------------------------- the renderer
SIZE = (96, 96)


def _scene():
    from mane.grooming import grow
    from mane.grooming.scene import default_head

    head = default_head()
    return grow(head, num_strands=60, style="curly", points_per_strand=12, seed=0), head


def _render(gl, rasterizer, bounce, head=True, light=None, pipeline="compute", oit="none"):
    groom, mesh = _scene()
    s = RenderSettings(size=SIZE, rasterizer=rasterizer, ambient=0.0, background=(0, 0, 0), tone_mapping="none",
                       exposure=1.0, strands_per_guide=8, strand_spread=0.0, scalp_tint=0.0, skin_bounce=bounce,
                       draw_head=head, pipeline=pipeline, oit=oit)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(mesh)
        cam = r.default_camera()
        img = realtime_linear(r, cam, [light or Light("directional", (0.35, 0.8, 0.5), intensity=3.0)])
        return img, r.get_pass("skin_bounce").enabled(r.last_frame)
    finally:
        r.release()


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer,oit", [("compute", "none"), ("hardware", "none"), ("compute", "a_buffer"),
                                            ("hardware", "a_buffer")])
def test_bounce_lights_the_hair_warm(gl, rasterizer, oit):
    """The bounce adds warm light to the hair, with the default blending and with transparency
    (the compute rasteriser's OIT shades in its own kernels)."""
    off, on_off = _render(gl, rasterizer, 0.0, oit=oit)
    on, on_on = _render(gl, rasterizer, 1.0, oit=oit)
    assert not on_off and on_on
    hair = (on[..., 3] > 0.5) & (np.abs(on[..., :3] - off[..., :3]).sum(-1) > 0)
    assert hair.sum() > 50
    gain = (on[..., :3] - off[..., :3])[hair]
    if oit == "none":
        assert np.all(gain >= -1e-3)                   # only adds light
    else:
        # the compute A-buffer blends equal-depth fragments in an order that varies from run to run
        # (two renders of the same frame differ by up to 0.007 on llvmpipe): what it takes from a
        # pixel here and there stays under 1 % of what the bounce adds
        assert -gain[gain < 0].sum() <= 0.01 * gain[gain > 0].sum()
    total = gain.sum(axis=0)
    assert total.sum() > 0.02 * off[..., :3][hair].sum()   # a visible share of the hair's light
    assert total[0] > total[1] > total[2]              # red: the skin's colour


def _rendered_maps(gl):
    """The test scene's frame (compute rasteriser) and its reflective shadow map read back as
    mip chains, the gather's and the deep opacity's uniforms and hair points (the expanded strands)."""
    from mane.render.passes.base import _lighting_uniforms

    groom, mesh = _scene()
    s = RenderSettings(size=SIZE, rasterizer="compute", strands_per_guide=8, scalp_tint=0.0)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(mesh)
        frame = r.render(r.default_camera(), [Light("directional", (0.35, 0.8, 0.5), intensity=3.0)])
        p = r.get_pass("skin_bounce")
        levels = _built_levels(p)
        lv = frame.light_view
        lu = _lighting_uniforms(r, frame)
        pts = r.get_pass("expand").read()
        lo, hi = r.hair_bbox()
        box = sb.grid_box(lv.view_proj, lv.eye, lv.forward, lo - r.strand_pad(), hi + r.strand_pad())
        return dict(levels=levels, vp=np.asarray(lv.view_proj, np.float64), eye=np.asarray(lv.eye, np.float64),
                    fwd=np.asarray(lv.forward, np.float64), table=np.array(p.uniforms(lv)["u_rsm_samples"]),
                    occlusion=dict(dom_levels=levels[2], layers=lu["u_dom_layers"], density=lu["u_shadow_density"]),
                    points=pts[..., :3][pts[..., 3] > 0].astype(np.float64), box=box)
    finally:
        r.release()


@pytest.mark.gpu
def _built_levels(p) -> list:
    """The pass's three maps as the gather sees them: the levels it built read from the GPU (up
    to the deepest level its samples read), the smaller ones (which the gather never reads)
    continued by NumPy's 2 x 2 means so that the twins get a whole chain."""
    n, top = sb.RSM_SIZE, p._uniforms[2]
    out = []
    for t in (p.flux, p.geom, p.dom):
        got = [np.frombuffer(t.read(level=k), np.float32).reshape(n >> k, n >> k, 4).astype(np.float64)
               for k in range(top + 1)]
        out.append(got + sb.mipmaps(got[-1])[1:])
    return out


def test_glsl_grid_matches_numpy(gl, tmp_path):
    """skin_bounce_grid.comp (the pass's grid, read back) against its twin, the NumPy gather at
    every cell's centre, within 3e-3 (the gather's 2e-3 and the half floats' 5e-4; on a GPU, whose
    filter weights are fixed point, 3 % for 99 % of the cells and 10 % of the grid's largest value for
    all, the cells whose move to the skin a filter weight can tip left out: _snap_undecided); and the hair
    shaders' lookup (skin_bounce_grid in a probe) against the trilinear twin within 1 % of the
    grid's largest value (GL's filter weights are fixed point)."""
    from mane.gpu.capabilities import get_capabilities
    from mane.gpu.glsl import compute_shader
    from mane.render.bindings import TABLE, TEX_RSM_GRID
    from mane.render.passes.base import HERE, RENDER_DIR, _lighting_uniforms, set_uniforms

    groom, mesh = _scene()
    s = RenderSettings(size=SIZE, rasterizer="compute", strands_per_guide=8, scalp_tint=0.0)
    r = Renderer(s, ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(mesh)
        frame = r.render(r.default_camera(), [Light("directional", (0.35, 0.8, 0.5), intensity=3.0)])
        p = r.get_pass("skin_bounce")
        size = sb.grid_size(r)
        got = np.frombuffer(p.grid.read(), np.float16).reshape(size[2], size[1], size[0], 4)[..., :3].astype(np.float64)
        u = frame.targets["skin_rsm"][3]
        levels = _built_levels(p)
        lu = _lighting_uniforms(r, frame)
        lv = frame.light_view
        lo = np.array(u["u_bounce_grid_lo"])
        box = np.array([lo, lo + 1.0 / np.array(u["u_bounce_grid_inv"])])
        want = sb.grid_numpy(box, size, levels[0], levels[1], np.array(u["u_rsm_samples"]), lv.view_proj, lv.eye,
                             lv.forward, dom_levels=levels[2], layers=lu["u_dom_layers"], density=lu["u_shadow_density"])
        assert want.max() > 0.1 and np.count_nonzero(want[..., 0] > 1e-3) > 0.1 * want[..., 0].size
        scale = np.maximum(np.abs(want), 1e-3 * want.max())
        err = np.abs(got - want)
        if get_capabilities(gl).is_software:
            assert np.max(err / scale) < 3e-3, np.max(err / scale)
        else:   # fixed-point filter weights: the cells a weight can tip left out; 99 % of the rest within 3 %,
            undecided = _snap_undecided(box, size, levels)    # all within 10 % of the largest value (a centre
            assert undecided.mean() < 0.02, undecided.mean()  # at the skin: its nearest samples' depths and
            decided = err[~undecided]                         # normals move its fluence most; H200: 6.9 %)
            assert np.max(decided) < 0.1 * want.max(), np.max(decided) / want.max()
            assert np.percentile((err / scale)[~undecided], 99) < 0.03, np.percentile((err / scale)[~undecided], 99)

        # the lookup: random points over the grid's box and a little beyond it (clamped to its border)
        probe = _probe_source(tmp_path, "skin_bounce_grid")
        cs = compute_shader(gl, probe, {**TABLE, "SHADOWS": 2, "PCF": 1}, include_dirs=[HERE, RENDER_DIR])
        rng = np.random.default_rng(2)
        q = box[0] + rng.uniform(-0.1, 1.1, (500, 3)) * (box[1] - box[0])
        pts = sb.rsm_point(q[:, :2], q[:, 2], np.linalg.inv(np.asarray(lv.view_proj, np.float64)),
                           np.asarray(lv.eye, np.float64), np.asarray(lv.forward, np.float64))
        set_uniforms(cs, {k: u[k] for k in ("u_rsm_view_proj", "u_rsm_eye", "u_rsm_dir", "u_bounce_grid_lo",
                                            "u_bounce_grid_inv")})
        set_uniforms(cs, {"u_bounce_grid": TEX_RSM_GRID, "u_count": len(pts)})
        p.grid.use(TEX_RSM_GRID)
        pbuf = gl.buffer(np.c_[pts, np.ones(len(pts))].astype(np.float32).tobytes())
        obuf = gl.buffer(reserve=16 * len(pts))
        pbuf.bind_to_storage_buffer(0)
        obuf.bind_to_storage_buffer(1)
        cs.run(math.ceil(len(pts) / 64))
        gl.finish()
        look = np.frombuffer(obuf.read(), np.float32).reshape(-1, 4)[:, :3]
        pbuf.release()
        obuf.release()
        twin = sb.grid_lookup_numpy(pts.astype(np.float32).astype(np.float64), got, box, lv.view_proj, lv.eye, lv.forward)
        assert np.max(np.abs(look - twin)) < 0.01 * got.max(), np.max(np.abs(look - twin)) / got.max()
    finally:
        r.release()


def test_trilinear_twin_reproduces_linear_fields():
    """The twins' trilinear look-up: exact for a field linear in (u, v, depth) inside the grid
    (cell centres at (i + 1/2) / n), and the border cells' value outside it."""
    size = (5, 4, 3)
    box = np.array([[0.2, 0.3, 1.0], [0.6, 0.9, 1.5]])
    c = sb.grid_centres(box, size)
    f = lambda q: np.stack([1 + 2 * q[..., 0] - q[..., 1], 3 * q[..., 2], q[..., 0] + q[..., 1] + q[..., 2]], -1)
    grid = f(c)
    rng = np.random.default_rng(0)
    lo, hi = c[0, 0, 0], c[-1, -1, -1]
    q = lo + rng.uniform(size=(200, 3)) * (hi - lo)
    np.testing.assert_allclose(sb.trilinear(grid, (q - box[0]) / (box[1] - box[0])), f(q), atol=1e-12)
    far = np.array([[box[1, 0] + 1.0, lo[1], lo[2]]])   # beyond the last column: that column's value
    np.testing.assert_allclose(sb.trilinear(grid, (far - box[0]) / (box[1] - box[0])),
                               f(np.array([[hi[0], lo[1], lo[2]]])), atol=1e-12)


@pytest.mark.gpu
def test_grid_follows_the_gather_at_the_hair_points(gl):
    """The grid (the GPUs' 64^3 and the CPU rasterisers' 32^3) read at the hair's points against
    the gather at those points, both twins on the test scene's real map: the bounce summed over
    the points within 10 % (measured 1.004 / 0.957), and the mean absolute difference a point
    under 20 % / 35 % of the mean bounce (measured 0.106 / 0.212): the gather's field has
    centimetre structure near the skin (the hair's opacity in the skin's column, the skin's
    nearest samples) that cells of 0.7-1.5 cm smooth; docs/quality.md item (10)."""
    m = _rendered_maps(gl)
    x = m["points"]
    direct = sb.gather_numpy(x, m["levels"][0], m["levels"][1], m["table"], m["vp"], m["eye"], m["fwd"], **m["occlusion"])
    lum = np.array([0.2126, 0.7152, 0.0722])
    ref = direct @ lum
    assert ref.mean() > 1e-3
    for size in {sb.GRID_SIZE_SOFTWARE, sb.GRID_SIZE}:
        grid = sb.grid_numpy(m["box"], size, m["levels"][0], m["levels"][1], m["table"], m["vp"], m["eye"], m["fwd"],
                             **m["occlusion"])
        got = sb.grid_lookup_numpy(x, grid, m["box"], m["vp"], m["eye"], m["fwd"]) @ lum
        assert abs(got.sum() / ref.sum() - 1.0) < 0.10, (size, got.sum() / ref.sum())
        bound = {sb.GRID_SIZE: 0.20, sb.GRID_SIZE_SOFTWARE: 0.35}[size]
        assert np.abs(got - ref).mean() < bound * ref.mean(), (size, np.abs(got - ref).mean() / ref.mean())


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_grid_renders_as_the_gather(gl, monkeypatch, rasterizer):
    """The frame with the grid (llvmpipe: 32^3) against the gather at every shaded point (base.SKIN_BOUNCE_GRID
    False): the light the bounce adds within 15 % in each channel (measured 0.92x compute, 0.90x
    hardware: this sparse groom shows many roots, where the grid smooths the peak by the skin), and
    the hair pixels within 5 % on average (measured 2.6 %, 2.7 %)."""
    from mane.render.passes import base

    imgs = {}
    for grid in (True, False):
        monkeypatch.setattr(base, "SKIN_BOUNCE_GRID", grid)
        imgs[grid], _ = _render(gl, rasterizer, 1.0)
    off, _ = _render(gl, rasterizer, 0.0)
    hair = (off[..., 3] > 0.5) & (np.abs(imgs[False][..., :3] - off[..., :3]).sum(-1) > 0)
    assert hair.sum() > 50
    gains = {g: (imgs[g][..., :3] - off[..., :3])[hair].sum(axis=0) for g in imgs}
    assert np.all(gains[False] > 0.1)
    lum = np.array([0.2126, 0.7152, 0.0722])
    a, b = imgs[True][..., :3][hair] @ lum, imgs[False][..., :3][hair] @ lum
    np.testing.assert_allclose(gains[True], gains[False], rtol=0.15)
    assert np.mean(np.abs(a - b) / np.maximum(b, 1e-4)) < 0.05, np.mean(np.abs(a - b) / np.maximum(b, 1e-4))


@pytest.mark.gpu
@pytest.mark.parametrize("rasterizer", ["compute", "hardware"])
def test_no_head_or_off_changes_nothing(gl, rasterizer):
    """Without a drawn head the term is not compiled in: the image is the same bit for bit."""
    a, _ = _render(gl, rasterizer, 0.0, head=False)
    b, enabled = _render(gl, rasterizer, 1.0, head=False)
    assert not enabled
    assert np.array_equal(a, b)


def test_default_is_on():
    assert RenderSettings().skin_bounce == 1.0
