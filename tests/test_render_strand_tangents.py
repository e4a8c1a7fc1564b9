"""Each rendered strand's shading tangent: its own curve's direction (the clump's taper and a
stray's deviation differentiated, not its guide's), tilted per strand by settings.strand_spread
so that the strands of a clump do not catch the highlight as one flat patch (issue 12)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_render_compute import drawn_directions, expanded
from mane.groom import Groom
from mane.render import Renderer, RenderSettings
from mane.render.camera import Camera
from mane.render.capture import capture_segments
from test_render_tessellation import wavy_groom

pytestmark = pytest.mark.gpu


def angles(a, b):
    return np.degrees(np.arccos(np.clip(np.einsum("...i,...i->...", a, b), -1.0, 1.0)))


def test_tangents_follow_each_strands_own_curve(gl):
    # every strand a stray (the default 1.5 clump radii): a stray leaves its clump within a
    # fifth of the strand, its direction turning away from its guide's by several degrees. With
    # no spread the tangent the shading gets is the direction of the strand's own points (their
    # central differences), float32 round-off
    g = wavy_groom(guides=3, points=8)
    kw = dict(segments=80, strands_per_guide=32, stray_fraction=1.0)
    e = expanded(gl, g, strand_spread=0.0, **kw)
    fd = drawn_directions(e[:, :, :3])[:, 1:-1]
    t = e[:, 1:-1, 4:7].astype(np.float64)
    guide_t = np.repeat(e[::32, 1:-1, 4:7], 32, axis=0).astype(np.float64)
    assert np.percentile(angles(fd, guide_t), 99) > 4.0   # the guide's tangent would be off
    assert angles(t, fd).max() < 0.05


def test_strand_spread_tilts_each_strand_by_its_rms_angle(gl):
    # the tilt is Rayleigh-distributed with RMS strand_spread: over 3 x 64 strands and their
    # points the RMS angle to the untilted tangent is within 15% of it; the kept guide (strand 0
    # of each clump) is not tilted; the positions do not move
    g = wavy_groom(guides=3, points=8)
    kw = dict(segments=40, strands_per_guide=64)
    flat = expanded(gl, g, strand_spread=0.0, **kw)
    tilted = expanded(gl, g, strand_spread=6.0, **kw)
    np.testing.assert_array_equal(flat[..., :4], tilted[..., :4])
    a = angles(flat[..., 4:7].astype(np.float64), tilted[..., 4:7].astype(np.float64))
    guides = np.arange(len(a)) % 64 == 0
    assert a[guides].max() < 0.1   # float32 round-off of equal tangents
    rms = math.sqrt(np.mean(a[~guides] ** 2))
    assert abs(rms / 6.0 - 1.0) < 0.15, rms
    # the tilt turns along each strand (its direction twice per strand), not one fixed offset
    assert np.mean(angles(tilted[~guides, 0, 4:7] - flat[~guides, 0, 4:7],
                          tilted[~guides, 10, 4:7] - flat[~guides, 10, 4:7]) > 45.0) > 0.5


def tight_curls(guides: int = 3, points: int = 49) -> Groom:
    """Helices 3 mm in radius, 6 turns over 6 cm (8 guide points a turn): the default clump
    (6 mm) puts strands farther off their guide than its radius of curvature (3.8 mm), where a
    strand runs backwards along its guide."""
    t = np.linspace(0.0, 1.0, points)
    strands = []
    for g in range(guides):
        th = 2.0 * math.pi * 6.0 * t + g
        strands.append(np.c_[0.003 * np.cos(th) + 0.05 * g, -0.06 * t, 0.003 * np.sin(th)])
    return Groom.from_strands(strands)


def test_tangents_are_the_drawn_strands_direction_in_tight_curls(gl):
    # the compute expansion: each point's tangent is the direction from its previous point to
    # its next one (the strand as drawn, and as the path tracer's spline through the points
    # runs), at the roots and tips the one segment's. 65 points a strand: the work groups'
    # ends fall inside strands. The guide's own direction (strand 0 is the guide) is off by
    # more than 90 degrees at a tenth of the points here, which the offset's length alone did not see.
    g = tight_curls()
    e = expanded(gl, g, segments=64, strands_per_guide=16, strand_spread=0.0)
    t = e[:, :, 4:7].astype(np.float64)
    fd = drawn_directions(e[:, :, :3])
    guide_t = np.repeat(t[::16], 16, axis=0)
    assert np.mean(angles(fd, guide_t) > 90.0) > 0.05   # the case: strands running back along their guide
    assert angles(t, fd).max() < 0.05                   # float32 round-off


def test_spread_tilts_the_drawn_strands_direction(gl):
    # the per-strand tilt turns the drawn direction (not the guide's): the RMS angle to it is
    # strand_spread within 15%, the guides (strand 0 of each clump) untilted
    g = tight_curls()
    kw = dict(segments=64, strands_per_guide=64)
    flat = expanded(gl, g, strand_spread=0.0, **kw)
    tilted = expanded(gl, g, strand_spread=6.0, **kw)
    a = angles(flat[..., 4:7].astype(np.float64), tilted[..., 4:7].astype(np.float64))
    guides = np.arange(len(a)) % 64 == 0
    assert a[guides].max() < 0.1
    assert abs(math.sqrt(np.mean(a[~guides] ** 2)) / 6.0 - 1.0) < 0.15


def test_the_tessellation_pipeline_shades_the_same_direction(gl):
    # the tessellation evaluation stage has no neighbours at hand: it evaluates the strand a
    # step either side (on the neighbouring guide segment past its patch's ends). Against the
    # central differences of the points it draws (captured): float32 round-off
    g = tight_curls()
    r = Renderer(RenderSettings(size=(64, 48), msaa=1, pipeline="tessellation", segments=64, strands_per_guide=16,
                                strand_spread=0.0), ctx=gl, profile=False)
    try:
        r.set_strands(g)
        seg = capture_segments(r)
    finally:
        r.release()
    worst, n = 0.0, 0
    for i in np.unique(seg["id"]):
        m = seg["id"] == i
        order = np.argsort(seg["s0"][m])
        p0 = seg["p0"][m][order].astype(np.float64)
        p1 = seg["p1"][m][order].astype(np.float64)
        t0 = seg["t0"][m][order].astype(np.float64)
        fd = drawn_directions(np.concatenate([p0, p1[-1:]]))[1:-1]
        worst = max(worst, angles(t0[1:], fd).max())
        n += len(fd)
    assert n > 3 * 16 * 60
    assert worst < 0.1, worst


def test_collapsed_lod_points_keep_the_strands_direction(gl):
    # the distance LOD collapses a guide segment's last points onto its end, which the next
    # segment's first point meets but for the round-off of two cubics: their neighbours' direction
    # would be noise. Every point's tangent lies within 10 degrees of the nearest segment of
    # non-zero length before or after it (up to 150 degrees off without the guard, checked)
    g = wavy_groom(guides=3, points=8)
    r = Renderer(RenderSettings(size=(64, 48), msaa=1, segments=64, strands_per_guide=4, lod=True, lod_start=0.2,
                                lod_end=1.0, lod_percent=0.3, strand_spread=0.0), ctx=gl, profile=False)
    try:
        r.set_strands(g)
        r.render(Camera(eye=(0.3, 0.0, 0.9), target=(0.05, -0.15, 0.0), fov_y=30.0))
        e = r.get_pass("expand").read()
    finally:
        r.release()
    p, t = e[..., :3].astype(np.float64), e[..., 4:7].astype(np.float64)
    d = np.diff(p, axis=1)
    length = np.linalg.norm(d, axis=-1)
    assert np.mean(length < 1e-6) > 0.3   # the LOD collapsed segments
    worst = 0.0
    for i in range(len(p)):
        real = [k for k in range(d.shape[1]) if length[i, k] > 1e-5]
        for j in range(p.shape[1]):
            near = [k for k in real if k < j][-1:] + [k for k in real if k >= j][:1]
            worst = max(worst, min(angles(t[i, j], d[i, k] / length[i, k]) for k in near))
    assert worst < 10.0, worst


@pytest.mark.parametrize("mode", ["multi", "hybrid"])
def test_blended_strands_shade_their_drawn_direction(gl, mode):
    # the barycentric blends of three guides (and the hybrid's single-guide strands) take the
    # same tangent: their drawn points' direction, float32 round-off
    g = tight_curls(guides=6)
    e = expanded(gl, g, segments=64, strands_per_guide=16, strand_spread=0.0, interpolation_mode=mode)
    assert len(e) >= 6 * 16
    assert angles(e[:, :, 4:7].astype(np.float64), drawn_directions(e[:, :, :3])).max() < 0.05
