"""Strand multiplication: counts (also past the 64-isoline limit), clump offsets on a disc
perpendicular to the guide's tangent with root/tip taper, stable per-strand seeds."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mane.groom import Groom
from mane.render import Renderer, RenderSettings
from mane.render.capture import capture_segments
from mane.render.passes.base import PASS_SHADE, draw_hair, hair_program

pytestmark = pytest.mark.gpu


def bent_groom(guides: int = 3, points: int = 8) -> Groom:
    """Strands that leave sideways and bend down: the tangent turns by ~90 degrees."""
    t = np.linspace(0.0, 1.0, points)
    out = []
    for g in range(guides):
        a = 0.7 * g
        d = np.array([np.cos(a), 0.0, np.sin(a)])
        pts = np.outer(0.1 * np.sin(t * np.pi / 2), d) + np.outer(-0.15 * (1 - np.cos(t * np.pi / 2)), [0, 1, 0])
        out.append(pts + [0.05 * g, 0.0, 0.0])
    return Groom.from_strands(out)


def run_capture(gl, groom, **kw):
    base = dict(size=(64, 48), msaa=1, segments=21, stray_fraction=0.0)
    base.update(kw)
    r = Renderer(RenderSettings(**base), ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        counts = SimpleNamespace(rendered_strands=r.rendered_strands, rendered_segments=r.rendered_segments)
        return capture_segments(r), counts
    finally:
        r.release()


@pytest.mark.parametrize("spg", [1, 7, 64, 100])
def test_rendered_strand_count(gl, spg):
    g = bent_groom(guides=3, points=5)
    seg, r = run_capture(gl, g, strands_per_guide=spg, segments=8)
    ids = np.unique(seg["id"])
    assert len(ids) == 3 * spg == r.rendered_strands
    assert set(ids.tolist()) == {gi * spg + j for gi in range(3) for j in range(spg)}
    assert int((seg["s0"] == 0).sum()) == 3 * spg            # one root segment per strand
    assert seg["count"] == r.rendered_segments == 3 * spg * 4 * 2


def test_primitives_query_counts_lines(gl):
    """GL_PRIMITIVES_GENERATED over a line draw: one line per rendered segment."""
    g = bent_groom(guides=2, points=5)
    r = Renderer(RenderSettings(size=(64, 48), msaa=1, geometry="lines", strands_per_guide=70,
                                segments=8, shadows="none", draw_head=False), ctx=gl, profile=False)
    try:
        r.set_strands(g)
        r.render()
        q = gl.query(primitives=True)
        r.hdr_fbo().use()
        with q:
            draw_hair(r, hair_program(r, PASS_SHADE), r.camera_view(r.default_camera()))
        assert q.primitives == r.rendered_segments == 2 * 70 * 8
    finally:
        r.release()


def guide_curve(seg, gid, spg, groom):
    """s -> (the kept guide's drawn point, the guide curve's unit derivative there: the NumPy
    Catmull-Rom's; the drawn tangent is the points' direction, a fraction of a degree off it)."""
    from test_render_tessellation import curve

    m = seg["id"] == gid * spg
    s0 = seg["s0"][m].astype(np.float64)
    _, der = curve(groom.as_padded()[gid].astype(np.float64), "catmull_rom", s0)
    der /= np.linalg.norm(der, axis=1, keepdims=True)
    return {round(float(s), 5): (p, t) for s, p, t in zip(seg["s0"][m], seg["p0"][m], der)}


def test_clump_offsets_lie_on_discs_perpendicular_to_the_guide(gl):
    g = bent_groom()
    radius, root, tip = 0.01, 0.25, 0.5
    spg = 12
    seg, _ = run_capture(gl, g, strands_per_guide=spg, clump_radius=radius, clump_root=root, clump_tip=tip,
                         keep_guide=True)
    normals = []
    for gid in range(g.num_strands):
        guide = guide_curve(seg, gid, spg, g)
        for j in range(1, spg):
            m = seg["id"] == gid * spg + j
            for s, p in zip(seg["s0"][m], seg["p0"][m]):
                gp, gt = guide[round(float(s), 5)]
                off = p - gp
                n = np.linalg.norm(off)
                profile = (1 - s) * ((1 - s) * root + s) + s * ((1 - s) + s * tip)
                assert n <= radius * profile + 1e-6
                if n > 1e-5:
                    assert abs(np.dot(off / n, gt)) < 2e-3            # perpendicular to the tangent
                    if s < 0.05:
                        normals.append(gt)
        # at the root the clump is narrow (root taper), mid-strand wider
    # the discs follow the guides, not a world plane: root tangents differ between guides
    normals = np.array(normals)
    assert np.ptp(normals, axis=0).max() > 0.5


def test_offsets_use_the_whole_disc_and_taper(gl):
    g = bent_groom(guides=1)
    spg = 64
    seg, _ = run_capture(gl, g, strands_per_guide=spg, clump_radius=0.01, clump_root=0.2, clump_tip=0.5)
    guide = guide_curve(seg, 0, spg, g)
    by_s = {}
    for s, p, i in zip(seg["s0"], seg["p0"], seg["id"]):
        if i != 0:
            by_s.setdefault(round(float(s), 5), []).append(np.linalg.norm(p - guide[round(float(s), 5)][0]))
    s_keys = sorted(by_s)
    root_max = max(by_s[s_keys[0]])
    mid_max = max(by_s[min(s_keys, key=lambda s: abs(s - 0.5))])
    assert root_max < 0.25 * 0.01 + 1e-6 and mid_max > 0.6 * 0.01   # taper at the root, full width mid-way


def test_strays_leave_the_clump(gl):
    g = bent_groom(guides=2)
    seg, _ = run_capture(gl, g, strands_per_guide=64, clump_radius=0.01, stray_fraction=0.3, stray_amount=3.0)
    seg0, _ = run_capture(gl, g, strands_per_guide=64, clump_radius=0.01, stray_fraction=0.0)
    far = lambda sg: np.linalg.norm(sg["p1"] - sg["p0"], axis=1)  # noqa: E731
    assert len(seg["p0"]) == len(seg0["p0"])
    guide = {gid: guide_curve(seg0, gid, 64, g) for gid in range(2)}
    d = [np.linalg.norm(p - guide[i // 64][round(float(s), 5)][0]) for s, p, i in zip(seg["s0"], seg["p0"], seg["id"])]
    assert max(d) > 0.015 and far(seg).max() > 0


def test_seeds_are_stable_per_guide_and_strand(gl):
    g = bent_groom(guides=3)
    a, _ = run_capture(gl, g, strands_per_guide=9, stray_fraction=0.2)
    b, _ = run_capture(gl, g, strands_per_guide=9, stray_fraction=0.2)
    order = lambda s: np.lexsort((s["s0"], s["id"]))  # noqa: E731
    np.testing.assert_array_equal(a["p0"][order(a)], b["p0"][order(b)])
    # the same guide keeps its strands when other guides are dropped
    c, _ = run_capture(gl, g.subset([0, 1]), strands_per_guide=9, stray_fraction=0.2)
    keep = a["id"] < 18
    np.testing.assert_allclose(np.sort(a["p0"][keep], axis=0), np.sort(c["p0"], axis=0), atol=1e-7)


def test_simulator_buffer_is_read_in_place(gl):
    from mane.render.strand_buffers import StrandBuffers

    g = bent_groom(guides=2, points=6)
    sb = StrandBuffers.from_groom(gl, g)
    r = Renderer(RenderSettings(size=(64, 48), msaa=1, strands_per_guide=1), ctx=gl, profile=False)
    r.set_strands(sb)
    moved = g.points + np.array([0.0, 0.1, 0.0], np.float32)
    data = np.c_[moved, np.ones(len(moved), np.float32)].astype(np.float32)
    sb.positions.write(data.tobytes())      # what a simulation step does to its buffer
    r.strands_changed()
    seg = capture_segments(r)
    roots = seg["p0"][seg["s0"] == 0]
    np.testing.assert_allclose(np.sort(roots[:, 1]), np.sort(moved.reshape(2, 6, 3)[:, 0, 1]), atol=1e-6)
    r.release()
