"""GridBounds and GridFriction (Petrovic grid velocity smoothing) against NumPy twins."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import UsageError
from mane.sim.bounds import GridBounds, padded_box
from mane.sim.grid_friction import GridFriction
from reference import grid_reference as ref

pytestmark = pytest.mark.gpu

METHODS = ["atomic", "raster"]


def scene(n=2000, seed=0, pinned_every=40, spread=(0.3, 0.5, 0.2), offset=(0.1, 1.6, -0.05)):
    rng = np.random.default_rng(seed)
    p = np.zeros((n, 4), np.float32)
    p[:, :3] = rng.normal(size=(n, 3)) * spread + offset
    p[:, 3] = rng.uniform(0.5, 4.0, n)          # inverse masses
    if pinned_every:
        p[::pinned_every, 3] = 0.0
    v = np.zeros((n, 4), np.float32)
    v[:, :3] = rng.normal(size=(n, 3))
    v[:, 3] = rng.uniform(size=n)               # w must survive
    return p, v


def upload(gl, *arrays):
    return [gl.buffer(np.ascontiguousarray(a, np.float32).tobytes()) for a in arrays]


def read4(buf, n):
    return np.frombuffer(buf.read(), np.float32).reshape(-1, 4)[:n].copy()


# ------------------------------------------------------------------ bounds
def test_bounds_equal_numpy_min_max(gl):
    p, _ = scene(3001, seed=1)
    (pb,) = upload(gl, p)
    b = GridBounds(gl, margin=0.0, relative_margin=0.0, cubic=False)
    lo, hi = b.update(pb, len(p)).read()
    np.testing.assert_array_equal(lo, p[:, :3].min(axis=0))
    np.testing.assert_array_equal(hi, p[:, :3].max(axis=0))


@pytest.mark.parametrize("cubic", [True, False])
def test_bounds_padding_and_cube_match_twin(gl, cubic):
    p, _ = scene(777, seed=2)
    (pb,) = upload(gl, p)
    b = GridBounds(gl, margin=0.01, relative_margin=0.1, cubic=cubic)
    lo, hi = b.update(pb, len(p)).read()
    tlo, thi = padded_box(p[:, :3], margin=0.01, relative_margin=0.1, cubic=cubic)
    np.testing.assert_allclose(lo, tlo, rtol=0, atol=1e-6)
    np.testing.assert_allclose(hi, thi, rtol=0, atol=1e-6)
    assert np.all(lo < p[:, :3].min(axis=0)) and np.all(hi > p[:, :3].max(axis=0))
    if cubic:
        assert np.ptp(hi - lo) < 1e-5


def test_bounds_follow_particles_and_ignore_nan(gl):
    p, _ = scene(500, seed=3)
    (pb,) = upload(gl, p)
    b = GridBounds(gl, relative_margin=0.0, cubic=False)
    b.update(pb, len(p))
    q = p.copy()
    q[:, :3] += 5.0
    q[7, :3] = np.nan
    q[8, 0] = np.inf
    pb.write(q.tobytes())
    lo, hi = b.update(pb, len(q)).read()         # keys were reset by the previous update
    good = np.all(np.isfinite(q[:, :3]), axis=1)
    np.testing.assert_array_equal(lo, q[good, :3].min(axis=0))
    np.testing.assert_array_equal(hi, q[good, :3].max(axis=0))


def test_bounds_subset_and_fixed_box(gl):
    p, _ = scene(400, seed=4)
    (pb,) = upload(gl, p)
    b = GridBounds(gl, relative_margin=0.0, cubic=False)
    lo, hi = b.update(pb, 100).read()
    np.testing.assert_array_equal(lo, p[:100, :3].min(axis=0))
    b.set([-1, -2, -3], [1, 2, 3])
    lo, hi = b.read()
    np.testing.assert_array_equal(lo, [-1, -2, -3])
    np.testing.assert_array_equal(hi, [1, 2, 3])
    with pytest.raises(UsageError):
        b.set([0, 0, 0], [1, 0, 1])


# ------------------------------------------------------------------ splat
@pytest.mark.parametrize("method", METHODS)
def test_splat_equals_numpy_trilinear(gl, method):
    R = 16
    p, v = scene(2500, seed=5)
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, R, method, pinned_mass=2.0)
    gf.apply(pb, vb, len(p), friction=0.0)
    lo, hi = gf.bounds.read()
    m = ref.masses(p[:, 3], pinned_mass=2.0)
    want = ref.splat(p[:, :3], np.column_stack([m, m[:, None] * v[:, :3]]), lo, hi, R)
    got = gf.read_grid()
    scale = want[..., 0].max()
    # float32 weights (positions on a 16-node axis) and, for "atomic", 2^-32 quantisation
    np.testing.assert_allclose(got["density"], want[..., 0], rtol=0, atol=2e-6 * scale)
    np.testing.assert_allclose(got["momentum"], want[..., 1:], rtol=0, atol=1e-5 * scale)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
def test_splat_conserves_mass_and_momentum(gl, method):
    p, v = scene(3000, seed=6)
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, 12, method)
    gf.splat(pb, vb, len(p))
    g = gf.read_grid()
    m = ref.masses(p[:, 3])
    np.testing.assert_allclose(g["density"].sum(dtype=np.float64), m.sum(), rtol=2e-6)
    mom = (m[:, None] * v[:, :3]).sum(axis=0)
    np.testing.assert_allclose(g["momentum"].reshape(-1, 3).sum(axis=0, dtype=np.float64), mom,
                               rtol=0, atol=2e-5 * np.abs(m[:, None] * v[:, :3]).sum())
    gf.release()


def test_atomic_and_raster_agree_and_atomic_is_deterministic(gl):
    p, v = scene(2000, seed=7)
    grids = []
    for method in METHODS + ["atomic"]:
        pb, vb = upload(gl, p, v)
        gf = GridFriction(gl, 16, method)
        gf.splat(pb, vb, len(p))
        grids.append(gf.read_grid())
        gf.release()
    np.testing.assert_allclose(grids[0]["density"], grids[1]["density"], rtol=1e-6,
                               atol=1e-6 * grids[0]["density"].max())
    np.testing.assert_array_equal(grids[0]["density"], grids[2]["density"])
    np.testing.assert_array_equal(grids[0]["velocity"], grids[2]["velocity"])


# ------------------------------------------------------------------ gather
@pytest.mark.parametrize("method", METHODS)
def test_friction_one_takes_grid_velocity(gl, method):
    R = 16
    p, v = scene(2000, seed=8)
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, R, method)
    gf.apply(pb, vb, len(p), friction=1.0)
    out = read4(vb, len(p))
    lo, hi = gf.bounds.read()
    want, _, node_v = ref.grid_friction(p, v, lo, hi, R, 1.0)
    np.testing.assert_allclose(out[:, :3], want, rtol=0, atol=2e-5)
    pinned = p[:, 3] == 0
    np.testing.assert_array_equal(out[pinned], v[pinned])       # pinned particles untouched
    np.testing.assert_array_equal(out[:, 3], v[:, 3])            # w kept
    g = gf.read_grid()
    heavy = g["density"] > 1e-3 * g["density"].max()   # V = momentum / mass amplifies noise on light nodes
    np.testing.assert_allclose(g["velocity"][heavy], node_v[heavy], atol=2e-5)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
def test_friction_partial_matches_twin(gl, method):
    R = 8
    p, v = scene(1500, seed=9)
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, R, method)
    gf.apply(pb, vb, len(p), friction=0.3)
    lo, hi = gf.bounds.read()
    want, _, _ = ref.grid_friction(p, v, lo, hi, R, 0.3)
    np.testing.assert_allclose(read4(vb, len(p))[:, :3], want, rtol=0, atol=2e-5)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
def test_friction_zero_leaves_velocities(gl, method):
    p, v = scene(1000, seed=10)
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, 16, method)
    gf.apply(pb, vb, len(p), friction=0.0)
    np.testing.assert_array_equal(read4(vb, len(p)), v)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("friction", [0.05, 0.5, 1.0])
def test_uniform_field_unchanged(gl, method, friction):
    p, v = scene(1500, seed=11)
    v[:, :3] = [0.3, -1.2, 2.5]
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, 16, method)
    gf.apply(pb, vb, len(p), friction=friction)
    np.testing.assert_allclose(read4(vb, len(p))[:, :3], v[:, :3], rtol=0, atol=2e-6)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
def test_shared_bounds_clamp_outside_particles(gl, method):
    """A fixed box smaller than the groom: particles outside are clamped onto it, as in the twin."""
    R = 8
    p, v = scene(800, seed=12)
    pb, vb = upload(gl, p, v)
    lo, hi = np.array([-0.2, 1.3, -0.2]), np.array([0.4, 1.9, 0.1])
    bounds = GridBounds(gl).set(lo, hi)
    gf = GridFriction(gl, R, method)
    gf.apply(pb, vb, len(p), friction=0.8, bounds=bounds)
    want, _, _ = ref.grid_friction(p, v, lo.astype(np.float32), hi.astype(np.float32), R, 0.8)
    np.testing.assert_allclose(read4(vb, len(p))[:, :3], want, rtol=0, atol=2e-5)
    np.testing.assert_array_equal(bounds.read()[0], lo.astype(np.float32))
    gf.release()


def test_bad_arguments(gl):
    with pytest.raises(UsageError):
        GridFriction(gl, 16, "bogus")
    assert GridFriction(gl, 8, "splat").method == "atomic"          # the simulator's name
    assert GridFriction(gl, 8, "optimised_gpu").method == "raster"  # Woodhouse's name
    with pytest.raises(UsageError):
        GridFriction(gl, 1)
    gf = GridFriction(gl, 8)
    p, v = scene(10)
    pb, vb = upload(gl, p, v)
    with pytest.raises(UsageError):
        gf.apply(pb, vb, 10, friction=1.5)
    with pytest.raises(UsageError):
        gf.apply(pb, vb, 11, friction=0.5)
    gf.apply(pb, vb, 0, friction=0.5)      # no particles: a no-op
    gf.release()
