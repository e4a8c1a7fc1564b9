"""``mane.sim.state.rest_data`` (vectorised over strands) against the per-point loop it replaced
(kept here verbatim as the golden) and against the twin's ``bind_frames``, on random strands
with empty (zero-length) segments, folds back onto themselves and haircuts."""
from __future__ import annotations

import numpy as np
import pytest

from mane.sim import state
from mane.sim.state import rest_data, transform_points
from mane.twins import sim as ref


# ---------------------------------------------------------------------- the golden: the old code
def _old_frame_from_direction(t):
    S = len(t)
    helper = np.tile(np.array([0.0, 0.0, 1.0]), (S, 1))
    near = np.abs(t[:, 2]) > 0.9
    helper[near] = (1.0, 0.0, 0.0)
    y = np.cross(helper, t)
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    z = np.cross(t, y)
    return np.stack([t, y, z], axis=2)


def _old_min_rotation_from_x(u):
    c = u[:, 0]
    v = np.stack([np.zeros_like(c), -u[:, 2], u[:, 1]], axis=1)
    K = np.zeros((len(u), 3, 3))
    K[:, 0, 1], K[:, 0, 2] = -v[:, 2], v[:, 1]
    K[:, 1, 0], K[:, 1, 2] = v[:, 2], -v[:, 0]
    K[:, 2, 0], K[:, 2, 1] = -v[:, 1], v[:, 0]
    opposite = c < -1.0 + 1e-6
    denom = np.where(opposite, 1.0, 1.0 + c)
    R = c[:, None, None] * np.eye(3) + K + v[:, :, None] * v[:, None, :] / denom[:, None, None]
    R[opposite] = np.diag([-1.0, -1.0, 1.0])
    return R


def _old_haircut(rest, scale):
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    arc = np.concatenate([np.zeros((len(rest), 1)), np.cumsum(seg, axis=1)], axis=1)
    if np.all(scale >= 1.0):
        return rest.copy()
    cut = arc[:, -1] * scale
    a = np.minimum(arc, cut[:, None])
    N = rest.shape[1]
    j = (arc[:, None, :] <= a[:, :, None]).sum(axis=2) - 1
    j = np.clip(j, 0, N - 2)
    S_idx = np.arange(len(rest))[:, None]
    a0, a1 = arc[S_idx, j], arc[S_idx, j + 1]
    span = np.where(a1 - a0 > 0, a1 - a0, 1.0)
    w = np.clip((a - a0) / span, 0.0, 1.0)[..., None]
    return rest[S_idx, j] * (1 - w) + rest[S_idx, j + 1] * w


def _old_rest_data(base, scale, inv_mass):
    S, N, _ = base.shape
    rest = _old_haircut(base, scale)
    base_seg = np.linalg.norm(np.diff(base, axis=1), axis=2)
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    d_all = np.diff(rest, axis=1)
    info = np.zeros((S, N, 4))
    info[:, 1:, 0] = seg
    info[:, 1:, 1] = np.cumsum(seg, axis=1)
    e0, e1 = d_all[:, :-1], d_all[:, 1:]
    sn = np.linalg.norm(np.cross(e0, e1), axis=2)
    info[:, 2:, 2] = np.where((seg[:, :-1] > 1e-12) & (seg[:, 1:] > 1e-12),
                              np.arctan2(sn, np.einsum("snk,snk->sn", e0, e1)), 0.0)
    info[:, 1:, 3] = base_seg
    d = np.diff(rest, axis=1)
    t0 = d[:, 0] / np.maximum(seg[:, :1], 1e-30)
    t0[seg[:, 0] <= 1e-12] = (0.0, -1.0, 0.0)
    R0 = _old_frame_from_direction(t0)
    refs = np.zeros((S, N, 4))
    F = R0.copy()
    for k in range(N - 1):
        refs[:, k + 1, :3] = np.einsum("sji,sj->si", F, d[:, k])
        ok = seg[:, k] > 1e-12
        if np.any(ok):
            u = np.einsum("sji,sj->si", F[ok], d[ok, k] / seg[ok, k, None])
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            F[ok] = F[ok] @ _old_min_rotation_from_x(u)
    frames = np.zeros((S, 3, 4))
    frames[:, :, :3] = np.transpose(R0, (0, 2, 1))
    pos = np.concatenate([rest, inv_mass.reshape(S, N, 1)], axis=2)
    return {
        "rest_positions": pos.astype(np.float32).reshape(-1, 4),
        "rest_info": info.astype(np.float32).reshape(-1, 4),
        "shape_refs": refs.astype(np.float32).reshape(-1, 4),
        "root_frames": frames.astype(np.float32).reshape(-1, 4),
    }


# ---------------------------------------------------------------------- random strands
def strands(S: int = 400, N: int = 17, seed: int = 3) -> np.ndarray:
    """Random walks (segments 1-20 mm) with empty segments, exact folds (a segment reversing
    its predecessor), empty first segments, strands along +-z (the root frame's other helper)
    and fully collapsed strands."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(S, N - 1, 3))
    d *= rng.uniform(0.001, 0.02, size=(S, N - 1, 1)) / np.linalg.norm(d, axis=2, keepdims=True)
    d[rng.random((S, N - 1)) < 0.1] = 0.0                       # empty segments
    fold = np.nonzero(rng.random((S, N - 2)) < 0.05)
    d[fold[0], fold[1] + 1] = -d[fold[0], fold[1]]              # exact folds (opposite)
    d[:20, 0] = 0.0                                             # empty first segment
    d[20:40] = np.array([0.0, 0.0, 0.01]) * np.where(np.arange(20) % 2, 1, -1)[:, None, None]
    d[40:45] = 0.0                                              # a strand in one point
    roots = rng.uniform(-0.1, 0.1, size=(S, 1, 3))
    return np.concatenate([roots, roots + np.cumsum(d, axis=1)], axis=1)


def inv_mass(S, N):
    w = np.ones((S, N), np.float32)
    w[:, 0] = 0.0
    return w.reshape(-1)


def close(new, old):
    """Equal to float32 precision: a float64 result rounded to float32 may land one float32 step
    off when its float64 summation order changes."""
    np.testing.assert_allclose(new, old, rtol=3e-7, atol=3e-8)


@pytest.mark.parametrize("cut", [False, True])
def test_rest_data_matches_the_per_point_loop(cut):
    base = strands()
    S, N, _ = base.shape
    scale = np.random.default_rng(5).uniform(0.2, 1.0, S) if cut else np.ones(S)
    w = inv_mass(S, N)
    new, old = rest_data(base, scale, w), _old_rest_data(base, scale, w)
    assert new.keys() == old.keys()
    for name in old:
        assert new[name].dtype == np.float32 and new[name].shape == old[name].shape, name
        close(new[name], old[name])
    np.testing.assert_array_equal(new["rest_positions"], old["rest_positions"])
    # the input is left as it was (the uncut haircut hands back the array itself)
    np.testing.assert_array_equal(base, strands())


def test_rest_data_blocks_are_independent(monkeypatch):
    """Blocks of REST_CHUNK strands, some all uncut (the no-copy path), some partly cut, give
    what one block gives and what the old loop gives."""
    base = strands(S=300, seed=11)
    S, N, _ = base.shape
    scale = np.ones(S)
    scale[150:300:7] = np.linspace(0.3, 0.95, len(scale[150:300:7]))
    w = inv_mass(S, N)
    whole = rest_data(base, scale, w)
    monkeypatch.setattr(state, "REST_CHUNK", 37)
    blocks = rest_data(base, scale, w)
    old = _old_rest_data(base, scale, w)
    for name in old:
        np.testing.assert_array_equal(blocks[name], whole[name])
        close(blocks[name], old[name])


def test_rest_data_bind_frames_match_the_twin():
    base = strands(S=120, N=12, seed=8)
    S, N, _ = base.shape
    R0, refs = ref.bind_frames(base)
    got = rest_data(base, np.ones(S), inv_mass(S, N))
    np.testing.assert_allclose(got["shape_refs"].reshape(S, N, 4)[:, 1:, :3], refs[:, 1:], atol=1e-7)
    np.testing.assert_allclose(got["root_frames"].reshape(S, 3, 4)[:, :, :3], R0.transpose(0, 2, 1), atol=1e-7)
    np.testing.assert_allclose(got["shape_refs"].reshape(S, N, 4)[:, :, 3], 0.0)


def test_rest_data_has_folds_and_empty_segments():
    """The random strands reach the branches under test (else the comparisons prove little)."""
    d = np.diff(strands(), axis=1)
    seg = np.linalg.norm(d, axis=2)
    assert (seg == 0).mean() > 0.05
    cos = np.einsum("snk,snk->sn", d[:, :-1], d[:, 1:]) / np.maximum(seg[:, :-1] * seg[:, 1:], 1e-30)
    assert (cos < -1 + 1e-9).sum() > 50


def test_transform_points_identity_and_rigid():
    p = np.random.default_rng(1).normal(size=(50, 3)).astype(np.float32)
    np.testing.assert_array_equal(transform_points(np.eye(4), p), p.astype(np.float64))
    m = np.eye(4)
    m[:3, :3] = ref.axis_angle(np.array([0.0, 0.6, 0.8]), 0.7)
    m[:3, 3] = (0.1, -0.2, 0.3)
    np.testing.assert_allclose(transform_points(m, p), ref.apply(m, p.astype(np.float64)), rtol=1e-12, atol=1e-12)
