"""Each rendered strand's shading tangent: its own curve's direction (the clump's taper and a
stray's deviation differentiated, not its guide's), tilted per strand by settings.strand_spread
so that the strands of a clump do not catch the highlight as one flat patch (issue 12)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_render_compute import expanded
from test_render_tessellation import wavy_groom

pytestmark = pytest.mark.gpu


def finite_difference_directions(e):
    """Unit central-difference directions of the expanded points (strands, points - 2, 3)."""
    p = e[:, :, :3].astype(np.float64)
    d = p[:, 2:] - p[:, :-2]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def angles(a, b):
    return np.degrees(np.arccos(np.clip(np.einsum("...i,...i->...", a, b), -1.0, 1.0)))


def test_tangents_follow_each_strands_own_curve(gl):
    # every strand a stray (the default 1.5 clump radii): a stray leaves its clump within a
    # fifth of the strand, its direction turning away from its guide's by several degrees. With
    # no spread the tangent the shading gets is the direction of the strand's own points
    # (central differences of 80 segments) within 1.5 degrees for 99.9% of the points (the
    # transported frame's own turning, times the offset, is left out: up to ~1 degree here)
    g = wavy_groom(guides=3, points=8)
    kw = dict(segments=80, strands_per_guide=32, stray_fraction=1.0)
    e = expanded(gl, g, strand_spread=0.0, **kw)
    fd = finite_difference_directions(e)
    t = e[:, 1:-1, 4:7].astype(np.float64)
    guide_t = np.repeat(e[::32, 1:-1, 4:7], 32, axis=0).astype(np.float64)
    assert np.percentile(angles(fd, guide_t), 99) > 4.0   # the guide's tangent would be off
    assert np.percentile(angles(t, fd), 99.9) < 1.5


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
