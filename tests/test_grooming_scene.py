"""The default scene from first principles: hair off the face, the scalp covered from every side,
and a camera that frames the head and shoulders."""
from __future__ import annotations

import numpy as np
import pytest

from mane.grooming import grow
from mane.grooming.head import FACE_BOX, default_head, scalp_faces
from mane.grooming.styles import PRESETS, parted_comb, trim_before_box
from mane.render.camera import Camera


@pytest.fixture(scope="module")
def head():
    return default_head(4)


@pytest.fixture(scope="module")
def long_wavy(head):
    return grow(head, 1500, "long_wavy", 24, seed=3)


@pytest.mark.parametrize("style", sorted(PRESETS))
def test_no_strand_crosses_the_face(head, style):
    """No point of any strand lies in the box in front of the eyes, nose and mouth."""
    g = grow(head, 400, style, 24, seed=1)
    p = g.points.astype(np.float64)
    lo, hi = np.asarray(FACE_BOX[0]), np.asarray(FACE_BOX[1])
    assert not np.any(np.all((p >= lo) & (p <= hi), axis=1))
    # the box really lies in front of the face: rays through it along -Z hit the head's eyes,
    # nose and mouth (the box is not a hiding place somewhere off the head)
    from mane.grooming.head import head_sdf

    for x, y in ((0.032, 0.0), (0.0, -0.03), (0.0, -0.065)):
        zs = np.linspace(0.25, 0.0, 2001)
        f = head_sdf(np.stack([np.full_like(zs, x), np.full_like(zs, y), zs], axis=1))
        z = zs[np.argmax(f < 0)]
        assert lo[2] < z < hi[2] and lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1]


def test_the_box_cut_keeps_strands_whole_and_shorter():
    # a straight strand along +X through a box at x in [0.5, 0.7]: cut 0.1 before it
    p = np.zeros((2, 11, 3))
    p[:, :, 0] = np.linspace(0.0, 1.0, 11)
    p[1, :, 1] = 5.0  # the second strand passes beside the box
    out, cut = trim_before_box(p, (0.5, -0.1, -0.1), (0.7, 0.1, 0.1), 0.1)
    assert cut.tolist() == [True, False]
    np.testing.assert_allclose(out[0, :, 0], np.linspace(0.0, 0.4, 11))
    np.testing.assert_array_equal(out[1], p[1])


def test_parting_combs_away_from_the_line():
    """Left of the parting hair goes to -X, right of it to +X; over the front it goes back."""
    pts = np.array([[0.01, 0.11, 0.04], [0.04, 0.11, 0.04], [-0.03, 0.11, 0.02], [0.0, 0.0, -0.1]])
    w = parted_comb(pts, 0.022)
    assert w[0, 0] < 0 and w[1, 0] > 0 and w[2, 0] < 0
    assert np.all(w[:3, 2] < 0)           # back, off the face
    assert w[3, 1] < -0.8                 # behind the crown: down
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), 1.0)


def _hits(origins, direction, tree, radius, reach=0.4, step=0.002):
    t = np.arange(step, reach, step)
    pts = origins[:, None, :] + t[None, :, None] * direction
    d, _ = tree.query(pts.reshape(-1, 3), distance_upper_bound=radius)
    return np.isfinite(d).reshape(len(origins), len(t)).any(axis=1)


def test_hair_covers_the_scalp_from_every_side(head, long_wavy):
    """From 8 directions (top, back, both sides, four diagonals: every side the hair grows on),
    a ray from each visible scalp point outward meets a strand within 3 mm (so a ray coming in
    from outside meets hair before the scalp): at least 97% of them from the back and the sides,
    88% from above (the parting line shows scalp, as a parting does), 95% over all."""
    from scipy.spatial import cKDTree

    g = long_wavy.resampled(96)  # points at most ~3 mm apart along the strands
    tree = cKDTree(g.points.astype(np.float64))
    tri = head.triangles.astype(np.float64)
    sf = scalp_faces(head)
    centres = tri[sf].mean(axis=1)
    normals = head.face_normals()[sf]
    dirs = {"top": (0, 1, 0), "back": (0, 0, -1), "left": (-1, 0, 0), "right": (1, 0, 0),
            "back-left": (-1, 0.3, -1), "back-right": (1, 0.3, -1), "top-left": (-1, 1, 0.3),
            "top-right": (1, 1, 0.3)}
    fractions = {}
    for name, d in dirs.items():
        d = np.asarray(d, float) / np.linalg.norm(d)
        seen = normals @ d > 0.5  # scalp facing this direction
        assert seen.sum() > 20, name
        hit = _hits(centres[seen] + 0.0005 * normals[seen], d, tree, 0.003)
        fractions[name] = hit.mean()
        assert hit.mean() >= (0.88 if name.startswith("top") else 0.97), (name, hit.mean())
    assert np.mean(list(fractions.values())) >= 0.95, fractions


def test_framing_points_fill_the_frame():
    """A camera framed on points sees them all and spans the frame in its tighter direction."""
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(500, 3)) * [0.1, 0.2, 0.1] + [0.3, 1.5, -0.2]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    for az, aspect in ((0.0, 16 / 9), (35.0, 1.0), (180.0, 4 / 3)):
        cam = Camera.framing(lo, hi, azimuth=az, elevation=10.0, aspect=aspect, points=pts, margin=1.05)
        q = np.c_[pts, np.ones(len(pts))] @ cam.view_projection(aspect).T
        ndc = q[:, :2] / q[:, 3:4]
        assert np.abs(ndc).max() <= 1.0 + 1e-9
        span = (ndc.max(axis=0) - ndc.min(axis=0)) / 2
        assert span.max() >= 0.85          # tight: ~1/1.05 of the frame, less perspective
        boxed = Camera.framing(lo, hi, azimuth=az, elevation=10.0, aspect=aspect, margin=1.05)
        qb = np.c_[pts, np.ones(len(pts))] @ boxed.view_projection(aspect).T
        assert span.max() > (np.ptp(qb[:, :2] / qb[:, 3:4], axis=0) / 2).max()  # tighter than the box


def test_the_bob_has_a_fringe_that_stops_above_the_eyes(head):
    """Strands from the forehead hang in front of it and end above the face box (the brows)."""
    g = grow(head, 800, "bob", 24, seed=2)
    roots, tips = g.roots.astype(np.float64), g.tips.astype(np.float64)
    lo, hi = np.asarray(FACE_BOX[0]), np.asarray(FACE_BOX[1])
    front = (roots[:, 2] > 0.05) & (np.abs(roots[:, 0]) < 0.03)
    assert front.sum() >= 5
    fringe = tips[front]
    assert np.all(fringe[:, 2] > 0.06)          # in front of the forehead, not combed back
    assert np.all(fringe[:, 1] > hi[1])         # above the eyes
    assert np.median(fringe[:, 1]) < roots[front, 1].min()  # hanging down from the hairline


def test_default_camera_frames_head_and_shoulders(gl):
    """`mane render`'s default view of the default scene: the hair spans most of the frame's
    height and its points fall in at least 30% of the frame's 20-pixel cells (a projection in
    NumPy of what the camera sees); the bust is cut at mid-chest, not shown whole."""
    from mane.render import Renderer, RenderSettings
    from mane.render.renderer import DEFAULT_HEAD_FRAME_FLOOR
    from mane.grooming.scene import default_groom

    head = default_head(4)
    groom = default_groom(head, num_guides=1000)
    w, h = 640, 480
    r = Renderer(RenderSettings(size=(w, h)), ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = r.default_camera()
    finally:
        r.release()
    hair = groom.points.astype(np.float64)
    q = np.c_[hair, np.ones(len(hair))] @ cam.view_projection(w / h).T
    ndc = q[:, :2] / q[:, 3:4]
    seen = np.all(np.abs(ndc) <= 1, axis=1)
    cells = np.zeros((w // 20, h // 20), bool)
    ij = ((ndc[seen] + 1) / 2 * cells.shape).astype(int).clip(0, np.array(cells.shape) - 1)
    cells[ij[:, 0], ij[:, 1]] = True
    assert cells.mean() >= 0.30
    assert np.ptp(ndc[seen, 1]) / 2 >= 0.8
    # everything above mid-chest is in the frame; most of the bust's base (its flat cut at
    # -0.40 m) is not (the camera looks down a little: the front edge just shows)
    above = hair[:, 1] >= DEFAULT_HEAD_FRAME_FLOOR
    assert seen[above].all()
    base = head.vertices[head.vertices[:, 1] < -0.385].astype(np.float64)
    qb = np.c_[base, np.ones(len(base))] @ cam.view_projection(w / h).T
    assert np.mean(qb[:, 1] / qb[:, 3] < -1.0) >= 0.75


def _scalp_samples(head, n=40000, seed=7):
    """Points uniform by area on the default head's scalp (weight >= 0.5), drawn here in NumPy
    (not by the follicle sampler under test)."""
    from mane.grooming.head import scalp_weight

    rng = np.random.default_rng(seed)
    tri = head.triangles.astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    f = rng.choice(len(tri), n, p=area / area.sum())
    s, r = np.sqrt(rng.random(n)), rng.random(n)
    pts = (1 - s)[:, None] * tri[f, 0] + (s * (1 - r))[:, None] * tri[f, 1] + (s * r)[:, None] * tri[f, 2]
    return pts[scalp_weight(pts) >= 0.5]


@pytest.fixture(scope="module")
def default_guides(head):
    from mane.grooming.scene import default_groom

    return default_groom(head, num_guides=1000)


def test_default_roots_leave_no_bald_patch(head, default_guides):
    """The default groom's 1000 guide roots cover the scalp evenly: under 1% of it lies farther
    than 8 mm from every root. Uniform random roots leave exp(-N pi r^2 / A) of it (Poisson:
    3.9% for N = 1000, r = 8 mm, A = 620 cm^2), bald patches that the clumps of rendered strands
    around each guide showed; blue noise leaves none but at the hairline's edge."""
    from scipy.spatial import cKDTree

    pts = _scalp_samples(head)
    assert len(pts) > 3000
    d, _ = cKDTree(default_guides.roots.astype(np.float64)).query(pts)
    assert (d > 0.008).mean() < 0.01, (d > 0.008).mean()
    assert d.max() < 0.012


def test_default_clumps_meet_at_the_roots(default_guides):
    """A guide's clump of rendered strands is at least as wide at the root as the guides are
    apart (median distance to the nearest other root): the clumps meet on the scalp instead of
    standing as 3 mm teeth 6 mm apart along the hairline and the parting."""
    from scipy.spatial import cKDTree

    from mane.grooming.scene import DEFAULT_SCENE_RENDER
    from mane.render import RenderSettings

    s = RenderSettings(**DEFAULT_SCENE_RENDER)
    roots = default_guides.roots.astype(np.float64)
    nn, _ = cKDTree(roots).query(roots, k=2)
    assert 2 * s.clump_root * s.clump_radius >= np.median(nn[:, 1])


def test_front_hair_sweeps_back_and_the_parting_reaches_the_crown():
    """Over the front, hair beside the parting is combed back at least as much as sideways
    (combed straight sideways it lay along the hairline as bars); just behind the top of the
    head (z = -0.01 m) it still parts sideways instead of already falling down the back."""
    front = np.array([[0.026, 0.09, 0.06], [0.018, 0.09, 0.06], [0.06, 0.08, 0.05], [-0.03, 0.1, 0.04]])
    w = parted_comb(front, 0.022)
    assert np.all(-w[:, 2] >= np.abs(w[:, 0])), w
    crown = np.array([[0.03, 0.12, -0.01], [0.01, 0.12, -0.01]])
    w = parted_comb(crown, 0.022)
    assert w[0, 0] > 0 > w[1, 0]
    assert np.all(np.abs(w[:, 0]) > np.abs(w[:, 1])), w
