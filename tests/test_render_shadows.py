"""Hair shadow methods against an exact CPU ray cast (src/mane/twins/shadow.py).

A small groom (a curtain of 50 wavy guides x 4 strands, 1 mm wide, 6600 rendered segments)
lit from the side; 2000 sample points (1500 within 2..8 mm of a strand, 500 anywhere in the
groom's box). The exact transmittance is prod(1 - alpha) over the strands each point's ray
toward the light crosses, alpha = 0.3, with the segments the renderer draws (captured). Each
method's own look-up (``light0_visibility`` in lighting.glsl) is evaluated at the same points
by a compute shader (mane.render.shadow_probe). With strand_opacity = -ln(1 - alpha) and
shadow_density = 1 the opacity methods estimate the same product (one strand: exp(-0.357) = 0.7).

Measured mean absolute transmittance errors (llvmpipe, maps 512^2, PCF 1: bilinear between the
4 nearest texels, density 64^3; the tolerances below leave about 25% room):

    shadow_map 0.247   adsm 0.112   deep_opacity 0.083   opacity_maps 0.069   density 0.094
    (no shadow at all: 0.40; with the nearest texel instead of bilinear weights: shadow_map
    0.258, adsm 0.119, deep_opacity 0.088, opacity_maps 0.074)
"""
from __future__ import annotations

import numpy as np
import pytest

from mane.bench.quality import (SHADOW_ALPHA, curtain_groom, points_near_segments, shadow_light, shadow_renderer,
                                shadow_settings)
from mane.errors import UsageError
from mane.render import Light, RenderSettings
from mane.render.capture import capture_segments
from mane.render.shadow_probe import probe_visibility

from mane.twins.shadow import crossings, exact_transmittance, segments_for_reference

pytestmark = pytest.mark.gpu

# the scene is mane.bench.quality's shadow validation scene
ALPHA = SHADOW_ALPHA
LIGHT = shadow_light()
BASE = shadow_settings(shadow_map_size=512)
# mean absolute transmittance error bound per method (measured values in the module docstring)
TOLERANCE = {"shadow_map": 0.33, "adsm": 0.15, "deep_opacity": 0.11, "opacity_maps": 0.095, "density": 0.125}


def make(gl, groom, **kw):
    return shadow_renderer(gl, groom, BASE, **kw)


@pytest.fixture(scope="module")
def scene(gl):
    groom = curtain_groom()
    r = make(gl, groom, shadows="none")
    try:
        r.render(None, [LIGHT])
        seg = segments_for_reference(capture_segments(r, view=r.light_view(LIGHT)))
        box = r.strands.bbox()
    finally:
        r.release()
    rng = np.random.default_rng(1)
    near = points_near_segments(seg, 1500, rng)
    points = np.concatenate([near, rng.uniform(box[0], box[1], (500, 3))])
    exact = exact_transmittance(points, seg["p0"], seg["p1"], seg["w0"], seg["w1"], seg["strand"], LIGHT.vector, ALPHA)
    return {"groom": groom, "points": points, "exact": exact, "segments": seg}


def method_visibility(gl, scene, shadows, **kw):
    r = make(gl, scene["groom"], shadows=shadows, **kw)
    try:
        r.render(None, [LIGHT])
        return probe_visibility(r, scene["points"]), r
    finally:
        r.release()


def test_reference_scene_is_not_trivial(scene):
    T = scene["exact"]
    assert 0.3 < (T < 1).mean() < 0.9                   # shadowed and lit points
    assert (T < 0.7 ** 3 + 1e-9).mean() > 0.1            # some behind 3 or more strands
    assert np.abs(1 - T).mean() > 0.3                    # "no shadow" is far off


@pytest.mark.parametrize("method", list(TOLERANCE) + ["deep_opacity/compute", "shadow_map/compute"])
def test_transmittance_against_exact_ray_cast(gl, scene, method):
    # .../compute: the maps built by the compute rasteriser (datacentre GPUs' default)
    method, _, raster = method.partition("/")
    got, r = method_visibility(gl, scene, method, rasterizer=raster or "hardware")
    assert r.compute_raster == (raster == "compute")
    err = np.abs(got - scene["exact"])
    print(f"\n{method}: mean |T - T_exact| = {err.mean():.4f} (bias {np.mean(got - scene['exact']):+.4f}, "
          f"tolerance {TOLERANCE[method]})")
    assert np.isfinite(got).all() and (got >= 0).all() and (got <= 1 + 1e-6).all()
    assert err.mean() < TOLERANCE[method]
    if method != "shadow_map":
        assert err.mean() < np.abs(1 - scene["exact"]).mean() / 2.5      # far better than no shadow


def test_exact_reference_on_hand_cases():
    # one segment along x at height 1, 2 mm wide; light straight up
    p0, p1 = np.array([[-1.0, 1.0, 0.0]]), np.array([[1.0, 1.0, 0.0]])
    w = np.array([0.002])
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0011], [0.0, 0.0, 0.0009], [0.0, 2.0, 0.0], [1.5, 0.0, 0.0]])
    n = crossings(pts, p0, p1, w, w, np.array([0]), (0.0, 1.0, 0.0))
    np.testing.assert_array_equal(n, [1, 0, 1, 0, 0])
    # a bent strand: the ray through its joint crosses it once; two strands: twice
    a = np.array([[-1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 2.0, 0.0]])
    b = np.array([[0.0, 1.0, 0.0], [1.0, 1.2, 0.0], [1.0, 2.0, 0.0]])
    ww = np.full(3, 0.01)
    n = crossings(np.array([[0.0, 0.0, 0.0]]), a, b, ww, ww, np.array([0, 0, 1]), (0.0, 1.0, 0.0))
    assert n[0] == 2
    T = exact_transmittance(np.array([[0.0, 0.0, 0.0]]), a, b, ww, ww, np.array([0, 0, 1]), (0.0, 1.0, 0.0), 0.25)
    np.testing.assert_allclose(T, [0.75 ** 2])


def test_opacity_map_slices(gl, scene):
    """16 slices in 4 targets, 32 in 8; every fragment in its own slice; the slices sum to the
    deep opacity map's last (cumulative) layer; the first non-empty slice holds z0."""
    for slices in (16, 32):
        r = make(gl, scene["groom"], shadows="opacity_maps", osm_slices=slices, shadow_map_size=128)
        try:
            frame = r.render(None, [LIGHT])
            p = r.get_pass("opacity_maps")
            assert len(p.maps) == slices // 4 and len(frame.targets["osm"]) == slices // 4
            osm = p.read()
            lo, hi = p.range
        finally:
            r.release()
        assert osm.shape == (128, 128, slices)
        # both maps drawn by the raster units (on datacentre GPUs "auto" builds the DOM by compute)
        d = make(gl, scene["groom"], shadows="deep_opacity", shadow_map_size=128, rasterizer="hardware")
        try:
            d.render(None, [LIGHT])
            dom = d.get_pass("deep_opacity").read()
        finally:
            d.release()
        covered = dom[..., 3] < 1e8
        assert covered.mean() > 0.05
        np.testing.assert_allclose(osm.sum(axis=2), dom[..., 2], rtol=1e-4, atol=1e-4)
        first = np.argmax(osm[covered] > 0, axis=1)
        want = np.clip(np.floor((dom[covered, 3] - lo) / (hi - lo) * slices), 0, slices - 1)
        assert np.mean(np.abs(first - want) <= 1) > 0.99
    for bad in (10, 36, 0):
        with pytest.raises(UsageError):
            RenderSettings(osm_slices=bad)


def test_deep_opacity_layer_boundaries(gl, scene):
    """Defaults 5% / 15% / rest of the hair's light depth extent, settable; deeper layer ends
    hold at least as much opacity, and the last layer (everything) does not move."""
    assert RenderSettings().dom_layers == (0.05, 0.15, 1.0)
    reads = {}
    for layers in ((0.05, 0.15, 1.0), (0.1, 0.3, 1.0)):
        r = make(gl, scene["groom"], shadows="deep_opacity", shadow_map_size=128, dom_layers=layers)
        try:
            frame = r.render(None, [LIGHT])
            reads[layers] = r.get_pass("deep_opacity").read()
            lo, hi = frame.hair_depth_range
        finally:
            r.release()
    a, b = reads[(0.05, 0.15, 1.0)], reads[(0.1, 0.3, 1.0)]
    covered = a[..., 3] < 1e8
    assert (b[covered, 0] >= a[covered, 0] - 1e-5).all() and (b[covered, 1] >= a[covered, 1] - 1e-5).all()
    assert b[covered, 0].sum() > a[covered, 0].sum() * 1.2
    np.testing.assert_allclose(a[..., 2], b[..., 2], atol=1e-5)
    # layer 1 by the OSM slices: opacity within 5% of the extent behind z0 (slices are 1/32 thick)
    for bad in ((0.2, 0.1, 1.0), (0.0, 0.1, 1.0), (0.1, 0.2)):
        with pytest.raises(UsageError):
            RenderSettings(dom_layers=bad)


@pytest.mark.parametrize("size", [128, 1024, 2048])
@pytest.mark.parametrize("method", ["shadow_map", "adsm", "deep_opacity", "opacity_maps"])
def test_map_sizes_allocate_and_render(gl, scene, size, method):
    """128^2 .. 2048^2 maps allocate, render and are looked up."""
    r = make(gl, scene["groom"], shadows=method, shadow_map_size=size)
    try:
        frame = r.render(None, [LIGHT])
        key = {"shadow_map": "shadow_map", "adsm": "adsm", "deep_opacity": "dom", "opacity_maps": "osm"}[method]
        tex = frame.targets[key]
        tex = tex[0] if isinstance(tex, list) else tex
        assert tex.size == (size, size)
        T = probe_visibility(r, scene["points"][:300])
        img = r.read_image()
    finally:
        r.release()
    assert (img.max(axis=2) > 0).any()
    assert 0.05 < T.mean() < 0.95


def test_density_splat_conserves_the_strands_cross_section(gl, scene):
    r = make(gl, scene["groom"], shadows="density", density_resolution=32)
    try:
        r.render(None, [LIGHT])
        p = r.get_pass("density")
        assert p.source == "strands"
        sigma = p.read()
        lo, hi = p.box()
    finally:
        r.release()
    seg = scene["segments"]
    want = np.sum(0.5 * (seg["w0"] + seg["w1"]) * np.linalg.norm(seg["p1"] - seg["p0"], axis=1)) * BASE["strand_opacity"]
    cell = (hi - lo) / (sigma.shape[0] - 1)
    np.testing.assert_allclose(sigma.sum() * np.prod(cell), want, rtol=1e-3)
    pts = np.asarray(scene["groom"].as_padded()).reshape(-1, 3)
    assert (pts >= lo).all() and (pts <= hi).all()


def test_density_from_the_simulators_grid(gl, scene):
    from mane.sim.settings import SimSettings
    from mane.sim.simulator import Simulator

    sim = Simulator(scene["groom"], settings=SimSettings(gravity=(0, 0, 0), friction=0.1, grid_resolution=32), ctx=gl)
    try:
        sim.step()
        out, total = {}, {}
        for source in ("strands", "simulator", "auto"):
            r = make(gl, sim, shadows="density", density_source=source, density_resolution=32)
            try:
                r.render(None, [LIGHT])
                p = r.get_pass("density")
                out[source] = probe_visibility(r, scene["points"])
                lo, hi = p.box()
                sig = p.read()
                total[source] = sig.sum() * np.prod((hi - lo) / (sig.shape[0] - 1))
                assert p.source == ("strands" if source == "strands" else "simulator")
            finally:
                r.release()
    finally:
        sim.release()
    np.testing.assert_allclose(total["simulator"], total["strands"], rtol=0.02)   # same hair, calibrated
    assert np.abs(out["simulator"] - out["strands"]).mean() < 0.12
    assert np.abs(out["simulator"] - scene["exact"]).mean() < 0.2
    # the simulator's grid needs one: without friction 'simulator' is refused, 'auto' splats
    r = make(gl, scene["groom"], shadows="density", density_source="simulator")
    try:
        with pytest.raises(UsageError):
            r.render(None, [LIGHT])
    finally:
        r.release()


def test_shadow_settings_are_checked():
    for kw in (dict(shadows="ray"), dict(density_source="grid"), dict(density_resolution=8),
               dict(adsm_spacing=0.0), dict(density_step=0.0)):
        with pytest.raises(UsageError):
            RenderSettings(**kw)
    for m in ("none", "shadow_map", "deep_opacity", "adsm", "opacity_maps", "density"):
        assert RenderSettings(shadows=m).shadows == m


@pytest.mark.parametrize("method", ["deep_opacity", "opacity_maps", "adsm"])
def test_shadow_lookups_have_no_texel_steps(gl, scene, method):
    # The light's visibility along lines across the hair, perpendicular to the light (constant
    # light depth), sampled 8 times per map texel: a look-up of the nearest texel is constant
    # inside a texel and jumps at its edges, so the 1/8 largest steps hold all the variation
    # (share 1.0, measured before the bilinear PCF); interpolated between texels the variation
    # spreads over each texel's 8 steps (measured 0.30 deep opacity, 0.30 opacity maps, 0.49 ADSM)
    r = make(gl, scene["groom"], shadows=method, shadow_map_size=128)
    try:
        r.render(None, [LIGHT])
        texel = r.light_view(LIGHT).pixel_size
        L = np.asarray(LIGHT.vector, float) / np.linalg.norm(LIGHT.vector)
        u = np.cross(L, [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        lo, hi = r.strands.bbox()
        t = np.arange(-96, 96) * texel / 8.0
        shares = []
        for y in np.linspace(-0.06, 0.06, 7):
            pts = 0.5 * (lo + hi) + np.outer(t, u) + np.array([0.0, y, 0.0]) - 0.004 * L
            steps = np.abs(np.diff(probe_visibility(r, pts).astype(np.float64)))
            if steps.sum() > 0.05:   # the line crosses some shadow
                shares.append(np.sort(steps)[::-1][:len(steps) // 8].sum() / steps.sum())
    finally:
        r.release()
    assert len(shares) >= 4
    assert np.mean(shares) < 0.6, shares


def _spheres_scene():
    """A 10 cm sphere at the origin and a 2.5 cm one between it and a grazing light, as one mesh."""
    import trimesh

    from mane.mesh import Mesh

    L = np.array([1.0, 0.3, 0.1]) / np.linalg.norm([1.0, 0.3, 0.1])
    spheres = [(np.zeros(3), 0.1), (np.array([0.0, 0.06, 0.06]) + 0.16 * L, 0.025)]
    verts, faces = [], []
    for c, rad in spheres:
        ico = trimesh.creation.icosphere(subdivisions=4, radius=rad)
        faces.append(np.asarray(ico.faces) + sum(len(v) for v in verts))
        verts.append(np.asarray(ico.vertices) + c)
    return Mesh(np.concatenate(verts).astype(np.float32), np.concatenate(faces).astype(np.int32)), spheres, L


@pytest.mark.parametrize("method", ["shadow_map", "deep_opacity"])
def test_surfaces_receive_shadows_without_acne(gl, method):
    # The head's own shadow map shading the head: a sphere lit at grazing angles must not shadow
    # its lit side (it is convex: nothing lies between it and the light, so every darkened pixel
    # is acne; with a constant 3-texel bias 53% of them were, in terraces and rings), while the
    # shadow a small sphere casts on it stays. Exact per pixel: the eye ray's hit on the spheres,
    # its normal, and whether its ray toward the light meets the small sphere (NumPy).
    from mane.render import Renderer
    from mane.render.camera import Camera

    mesh, spheres, L = _spheres_scene()
    n, eye = 128, np.array([0.0, 0.0, 0.5])
    cam = Camera(eye=tuple(eye), target=(0.0, 0.0, 0.0), fov_y=30.0, near=0.1, far=2.0)
    light = [Light("directional", tuple(L), (1.0, 1.0, 1.0), 3.0)]
    img = {}
    for shadows in ("none", method):
        r = Renderer(RenderSettings(size=(n, n), shadows=shadows, msaa=1, ambient=0.0), ctx=gl, profile=False)
        try:
            r.set_head(mesh)
            r.render(cam, light)
            img[shadows] = r.read_image().astype(np.float64).mean(axis=2)
        finally:
            r.release()

    def hit(o, d, c, rad):   # ray o + t d (unit d) against a sphere: t (inf: miss)
        oc = o - c
        b = np.einsum("...i,...i->...", d, oc)
        disc = b * b - (np.einsum("...i,...i->...", oc, oc) - rad * rad)
        t = -b - np.sqrt(np.maximum(disc, 0.0))
        return np.where((disc > 0) & (t > 1e-6), t, np.inf)

    ys, xs = np.mgrid[0:n, 0:n]
    tan = np.tan(np.radians(15.0))
    d = np.stack([((xs + 0.5) / n * 2 - 1) * tan, (1 - (ys + 0.5) / n * 2) * tan, -np.ones((n, n))], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    t_big, t_small = (hit(eye, d, c, rad) for c, rad in spheres)
    on_big = np.isfinite(t_big) & (t_big < t_small)
    P = eye + np.where(on_big, t_big, 0.0)[..., None] * d
    ndl = (P / spheres[0][1]) @ L
    toward = np.broadcast_to(L, P.shape)
    # the shadow's exact edge, widened by 3 mm either side (PCF, bias): pixels there are not judged
    c, rad = spheres[1]
    shadowed = np.isfinite(hit(P, toward, c, rad))
    core = np.isfinite(hit(P, toward, c, rad - 0.003))
    clear = ~np.isfinite(hit(P, toward, c, rad + 0.003))
    lit = on_big & (ndl > 0.1)
    darker = img["none"] - img[method]
    assert (lit & clear).sum() > 1500 and (lit & core).sum() > 40
    assert (darker[lit & clear] > 2.0).mean() < 0.01          # no acne on the lit, unshadowed side
    assert (darker[lit & core] > 10.0).mean() > 0.95          # the cast shadow is still there
    assert shadowed[lit].mean() < 0.5


def test_head_pcf_filters_the_skin_and_pcf_the_hair(gl):
    """The skin's shadow look-ups take ``head_pcf``, the hair's ``pcf``: on the two-sphere scene
    (a small sphere's shadow on a big one, the head pass alone) head_pcf widens the shadow's
    penumbra and pcf leaves the image as it is."""
    from mane.render import Renderer
    from mane.render.camera import Camera

    mesh, _, L = _spheres_scene()
    cam = Camera(eye=(0.0, 0.0, 0.5), target=(0.0, 0.0, 0.0), fov_y=30.0, near=0.1, far=2.0)
    light = [Light("directional", tuple(L), (1.0, 1.0, 1.0), 3.0)]

    def image(**kw):
        r = Renderer(RenderSettings(size=(96, 96), shadows="shadow_map", msaa=1, ambient=0.0, shadow_map_size=128, **kw),
                     ctx=gl, profile=False)
        try:
            r.set_head(mesh)
            r.render(cam, light)
            return r.read_image().astype(np.float64).mean(axis=2)
        finally:
            r.release()

    base = image(head_pcf=1, pcf=1)
    np.testing.assert_array_equal(image(head_pcf=1, pcf=5), base)
    wide = image(head_pcf=5, pcf=1)
    changed = np.abs(wide - base) > 2.0
    assert changed.sum() > 20, changed.sum()    # the penumbra's pixels,
    assert changed.mean() < 0.2                 # not the whole picture


def test_ms_shadow_footprint_feeds_the_multiple_scattering_only(gl, scene):
    """``ms_shadow_footprint`` N gives the multiple-scattering term light 0's deep-opacity
    transmittance over an N x N texel box (PCF_BOX), the direct light keeps the pcf box: N equal to
    pcf is the image of N = 0 (the same box, the same look-up), with multiple scattering off N
    changes nothing, and with dual scattering on a box other than pcf's changes the hair's light."""
    from mane.bench.fidelity import realtime_linear

    def image(ms="dual", **kw):
        r = make(gl, scene["groom"], shadows="deep_opacity", ambient=0.0, tone_mapping="none",
                 shading_options={"multiple_scattering": ms}, **kw)
        try:
            return realtime_linear(r, None, [LIGHT])[..., :3].astype(np.float64)
        finally:
            r.release()

    off = image(pcf=3, ms_shadow_footprint=0)
    assert off.max() > 0.01                                              # lit hair in the picture
    np.testing.assert_allclose(image(pcf=3, ms_shadow_footprint=3), off, rtol=0, atol=1e-6)
    direct = image(ms="none", pcf=1, ms_shadow_footprint=0)
    np.testing.assert_allclose(image(ms="none", pcf=1, ms_shadow_footprint=6), direct, rtol=0, atol=1e-6)
    bilinear, wide = image(pcf=1, ms_shadow_footprint=0), image(pcf=1, ms_shadow_footprint=6)
    changed = np.abs(wide - bilinear).max(axis=2) > 1e-3 * off.max()
    hair = off.max(axis=2) > 0
    assert changed.sum() > 0.3 * hair.sum(), (changed.sum(), hair.sum())    # llvmpipe: 238 of 303
    # and only through the scattered light: the difference is no larger than the MS term itself
    assert np.all(np.abs(wide - bilinear) <= np.abs(bilinear - direct) + np.abs(wide - direct) + 1e-6)
    with pytest.raises(UsageError):
        RenderSettings(ms_shadow_footprint=-1)


@pytest.mark.parametrize("method", ["deep_opacity", "shadow_map"])
def test_a_still_heads_shadow_map_is_drawn_once(gl, method, monkeypatch):
    """Where the hair does not cast into light 0's shadow map (every method but "shadow_map"), the
    map holds the head alone: it is drawn again only when the head, its transform or the light's
    view changes, and every frame is the picture a fresh renderer draws."""
    from mane.render import Renderer
    from mane.render.camera import Camera

    mesh, _, L = _spheres_scene()
    groom = curtain_groom(16, 8)
    cam = Camera(eye=(0.0, 0.05, 0.6), target=(0.0, 0.0, 0.0), fov_y=35.0)
    s = RenderSettings(size=(96, 72), shadows=method, shadow_map_size=256)

    def fresh(transform=None, light=L):
        r = Renderer(s, ctx=gl, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(mesh)
            if transform is not None:
                r.set_head_transform(transform)
            r.render(cam, [Light("directional", tuple(light), intensity=2.0)])
            return r.read_image(), r.get_pass("shadow_map").read()
        finally:
            r.release()

    moved = np.eye(4)
    moved[:3, 3] = (0.0, 0.02, 0.0)
    other = np.array([0.2, 0.9, 0.3]) / np.linalg.norm([0.2, 0.9, 0.3])
    r = Renderer(s, ctx=gl, profile=False)
    draws = []
    try:
        r.set_strands(groom)
        r.set_head(mesh)
        sm = r.get_pass("shadow_map")
        orig = sm.begin_depth
        monkeypatch.setattr(sm, "begin_depth", lambda *a, **k: (draws.append(1), orig(*a, **k)))
        steps = [(None, L), (None, L), (moved, L), (moved, L), (moved, other), (None, other)]
        for transform, light in steps:
            r.set_head_transform(np.eye(4) if transform is None else transform)
            r.render(cam, [Light("directional", tuple(light), intensity=2.0)])
            img, smap = r.read_image(), sm.read()
            want_img, want_map = fresh(transform, light)
            assert np.array_equal(smap, want_map)
            assert np.array_equal(img, want_img)
        r.set_head(mesh)   # a new head (the same mesh uploaded again): drawn again
        r.render(cam, [Light("directional", tuple(other), intensity=2.0)])
    finally:
        r.release()
    # drawn at the first frame, after the move, after the light turned, after the move back, after
    # set_head: the head alone by the pass's own memo, the hair casting into it as every
    # light-space target is kept (light_key.py)
    assert len(draws) == 5
