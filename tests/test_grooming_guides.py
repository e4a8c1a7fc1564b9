"""Guide selection and interpolation weights, and their NumPy reconstruction."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import ManeError
from mane.groom import Groom
from mane.grooming.guides import (GuideWeights, compute_guide_weights, make_guides, reconstruct,
                                  root_frames, select_guides)
from mane.grooming.head import default_head
from mane.grooming.styles import grow
from mane.mesh import Mesh


@pytest.fixture(scope="module")
def groom():
    return grow(default_head(), 3000, "wavy", 12, seed=2)


def upright_field(n=900, points=8, seed=0, shape=None):
    """Strands on the plane y = 0, all the same shape (a translation field)."""
    rng = np.random.default_rng(seed)
    roots = np.column_stack([rng.uniform(-0.05, 0.05, n), np.zeros(n), rng.uniform(-0.05, 0.05, n)])
    t = np.linspace(0, 1, points)
    if shape is None:
        shape = np.column_stack([0.02 * np.sin(6 * t), 0.1 * t, 0.01 * t * t])
    pts = roots[:, None, :] + shape[None, :, :]
    normals = np.tile([0.0, 1.0, 0.0], (n, 1)).astype(np.float32)
    return Groom(pts.reshape(-1, 3), np.full(n, points),
                 strand_attributes={"root_normal": normals})


@pytest.mark.parametrize("method", ["fps", "kmeans"])
def test_k_distinct_guides(groom, method):
    g = select_guides(groom, 100, method=method, seed=1)
    assert g.shape == (100,) and len(np.unique(g)) == 100
    assert g.min() >= 0 and g.max() < groom.num_strands
    np.testing.assert_array_equal(g, select_guides(groom, 100, method=method, seed=1))


def test_kmeans_with_as_many_guides_as_strands():
    f = upright_field(n=40)
    g = select_guides(f, 40, method="kmeans", seed=0)
    assert sorted(g.tolist()) == list(range(40))


def test_fps_spreads_guides(groom):
    g = select_guides(groom, 64, method="fps", seed=0)
    r = groom.roots.astype(np.float64)
    from scipy.spatial import cKDTree

    # every strand's root is near a guide: covering radius well below a random choice's
    cover = cKDTree(r[g]).query(r)[0].max()
    rnd = np.random.default_rng(0).choice(len(r), 64, replace=False)
    assert cover < cKDTree(r[rnd]).query(r)[0].max()
    # FPS: the minimum spacing among the guides is at least the covering radius
    d, _ = cKDTree(r[g]).query(r[g], k=2)
    assert d[:, 1].min() >= cover - 1e-9


def test_weights_sum_to_one_and_are_barycentric(groom):
    gw = make_guides(groom, 200, method="fps", seed=3)
    assert isinstance(gw, GuideWeights)
    assert gw.indices.dtype == np.int32 and gw.indices.shape == (3000, 3)
    assert gw.weights.dtype == np.float32 and gw.weights.shape == (3000, 3)
    assert gw.guide.dtype == np.int32 and gw.offset.dtype == np.float32
    np.testing.assert_allclose(gw.weights.sum(axis=1), 1.0, atol=1e-6)
    assert np.all(gw.weights >= 0)
    assert gw.inside.mean() > 0.8
    # inside: the root's projection is the weighted sum of the guide roots
    r = groom.roots.astype(np.float64)
    gr = r[gw.guides]
    proj = np.einsum("sk,skj->sj", gw.weights.astype(np.float64), gr[gw.indices])
    n = np.cross(gr[gw.indices[:, 1]] - gr[gw.indices[:, 0]], gr[gw.indices[:, 2]] - gr[gw.indices[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    resid = r - proj
    tangential = resid - (resid * n).sum(1, keepdims=True) * n
    assert np.abs(tangential[gw.inside]).max() < 1e-5
    # the single-strand guide is the nearest one
    d_all = np.linalg.norm(r[:, None, :] - gr[None, :, :], axis=2)
    np.testing.assert_allclose(d_all[np.arange(3000), gw.guide], d_all.min(axis=1), atol=1e-7)


def test_planar_weights_are_exact():
    # guides at the corners of a right triangle: barycentrics of a point are known in closed form
    guides = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0, 0.01]], dtype=np.float64)
    inner = np.array([[0.002, 0, 0.003], [0.005, 0, 0.001]])
    roots = np.concatenate([guides, inner])
    pts = np.stack([roots, roots + [0, 0.05, 0]], axis=1).reshape(-1, 3)
    g = Groom(pts, np.full(5, 2), strand_attributes={"root_normal": np.tile([0, 1.0, 0], (5, 1))})
    gw = compute_guide_weights(g, [0, 1, 2])
    expect = {3: {0: 0.5, 1: 0.2, 2: 0.3}, 4: {0: 0.4, 1: 0.5, 2: 0.1}}
    for s, want in expect.items():
        got = dict(zip(gw.indices[s].tolist(), gw.weights[s].tolist()))
        for k, v in want.items():
            assert got[k] == pytest.approx(v, abs=1e-6)
        assert gw.inside[s]


def test_reconstruction_from_three_identical_guides_is_the_guide():
    rng = np.random.default_rng(0)
    guide = np.cumsum(rng.normal(scale=0.01, size=(10, 3)), axis=0)
    G = np.stack([guide, guide, guide])
    frames = np.tile(np.eye(3), (3, 1, 1)).astype(np.float32)
    gw = GuideWeights(guides=np.arange(3), indices=np.array([[0, 1, 2], [2, 0, 1]], np.int32),
                      weights=np.array([[0.2, 0.3, 0.5], [1 / 3, 1 / 3, 1 / 3]], np.float32),
                      inside=np.ones(2, bool), guide=np.array([1, 2], np.int32),
                      offset=np.zeros((2, 3), np.float32), multi_offset=np.zeros((2, 3), np.float32),
                      guide_frames=frames)
    for method in ("multi", "single"):
        out = reconstruct(G, gw, method)
        np.testing.assert_allclose(out, np.stack([guide, guide]), atol=1e-7)


STRAIGHT = np.column_stack([0.03 * np.linspace(0, 1, 8), 0.1 * np.linspace(0, 1, 8), np.zeros(8)])


def test_reconstruct_a_translation_field_exactly():
    # straight strands: the guides' frames do not turn, so both methods are exact
    f = upright_field(shape=STRAIGHT)
    P = f.as_padded().astype(np.float64)
    gw = make_guides(f, 60, method="fps", seed=0)
    for method in ("single", "multi"):
        np.testing.assert_allclose(reconstruct(P[gw.guides], gw, method), P, atol=2e-6)
    # bent strands: the barycentric blend is exact wherever the root is inside its triangle
    f = upright_field()
    P = f.as_padded().astype(np.float64)
    gw = make_guides(f, 60, method="fps", seed=0)
    out = reconstruct(P[gw.guides], gw, "multi")
    assert gw.inside.mean() > 0.8
    np.testing.assert_allclose(out[gw.inside], P[gw.inside], atol=2e-6)


def test_guides_reconstruct_themselves(groom):
    gw = make_guides(groom, 150, method="kmeans", seed=0)
    P = groom.as_padded().astype(np.float64)
    G = P[gw.guides]
    for method in ("single", "multi"):
        out = reconstruct(G, gw, method)
        np.testing.assert_allclose(out[gw.guides], G, atol=2e-6)
        # every rendered root sits on its follicle
        np.testing.assert_allclose(out[:, 0], P[:, 0], atol=2e-6)


def test_offsets_follow_a_rotating_guide():
    # a guide that turns from +Y to +X: a strand offset along +X at the root (in the tangent
    # plane) ends up offset along -Y where the guide runs along +X
    guide = np.array([[0, 0, 0], [0, 0.01, 0], [0.01, 0.02, 0], [0.02, 0.02, 0], [0.03, 0.02, 0]], float)
    frames = root_frames(Groom(guide, [5], strand_attributes={"root_normal": [[0, 1.0, 0]]}))
    off_world = np.array([0.002, 0, 0])
    gw = GuideWeights(guides=np.array([0]), indices=np.zeros((1, 3), np.int32),
                      weights=np.array([[1, 0, 0]], np.float32), inside=np.ones(1, bool),
                      guide=np.zeros(1, np.int32),
                      offset=(frames[0] @ off_world)[None].astype(np.float32),
                      multi_offset=(frames[0] @ off_world)[None].astype(np.float32),
                      guide_frames=frames.astype(np.float32))
    for method in ("single", "multi"):
        out = reconstruct(guide[None], gw, method)[0]
        np.testing.assert_allclose(out[0], off_world, atol=1e-7)
        np.testing.assert_allclose(out[-1] - guide[-1], [0, -0.002, 0], atol=1e-7)


def test_root_offsets_are_world_space(groom):
    gw = make_guides(groom, 100, seed=0)
    r = groom.roots.astype(np.float64)
    blend = np.einsum("sk,skj->sj", gw.weights.astype(np.float64), r[gw.guides][gw.indices])
    np.testing.assert_allclose(blend + gw.root_offsets, r, atol=2e-6)


def test_bad_inputs(groom):
    with pytest.raises(ManeError, match="at most"):
        select_guides(groom, groom.num_strands + 1)
    with pytest.raises(ManeError, match="positive"):
        select_guides(groom, 0)
    with pytest.raises(ManeError, match="fps"):
        select_guides(groom, 5, method="random")
    with pytest.raises(ManeError, match="distinct"):
        compute_guide_weights(groom, [1, 1, 2])
    with pytest.raises(ManeError, match="no guides"):
        compute_guide_weights(groom, [])
    gw = make_guides(groom, 10)
    with pytest.raises(ManeError, match="guides given"):
        reconstruct(np.zeros((9, 12, 3)), gw)
    with pytest.raises(ManeError, match="single"):
        reconstruct(np.zeros((10, 12, 3)), gw, method="both")
    with pytest.raises(ManeError):
        Groom(np.zeros((0, 3)), np.zeros(0, int))  # zero strands


def test_few_guides():
    f = upright_field(n=30, shape=STRAIGHT)
    for k in (1, 2):
        gw = make_guides(f, k)
        np.testing.assert_allclose(gw.weights.sum(axis=1), 1.0, atol=1e-6)
        out = reconstruct(f.as_padded()[gw.guides].astype(np.float64), gw, "multi")
        np.testing.assert_allclose(out, f.as_padded(), atol=2e-6)
