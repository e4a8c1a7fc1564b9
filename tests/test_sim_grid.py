"""GridBounds and GridFriction (Petrovic grid velocity smoothing) against NumPy twins."""
from __future__ import annotations

import numpy as np
import pytest

from mane.errors import UsageError
from mane.gpu.bounds import GridBounds, padded_box
from mane.gpu.context import is_software_renderer
from mane.sim.grid_friction import (CELL_RUN, CHUNK, SORTED_COPY_MIN, SOFTWARE_CELL_CHUNK, GridFriction, _shared_limit,
                                    cell_splat_shared_bytes)
from mane.twins import grid as ref

pytestmark = pytest.mark.gpu

# atomic splats: schedule (binned / direct) x number format (float atomics / 64-bit fixed point);
# raster: vertex-shader layer (where the extension is) and geometry shader
VARIANTS = {
    "atomic": dict(method="atomic"),   # what a context gets by default
    "binned-fixed": dict(method="atomic", splat="binned", float_atomics=False),
    "binned-float": dict(method="atomic", splat="binned", float_atomics=True, aggregate=False),
    # the binned splat summing runs of particles in one cell in registers first (float sums only)
    "binned-float-run": dict(method="atomic", splat="binned", float_atomics=True, aggregate=True),
    # the scatter copying the particles in sorted order for the splat (the default from 20M particles)
    "binned-float-copy": dict(method="atomic", splat="binned", float_atomics=True, sorted_copy=True),
    "binned-fixed-copy": dict(method="atomic", splat="binned", float_atomics=False, sorted_copy=True),
    # each chunk walked in cell order (with the sorted copy; the last one reads through the order)
    "binned-float-cells": dict(method="atomic", splat="binned", float_atomics=True, cell_sort=True),
    "binned-fixed-cells": dict(method="atomic", splat="binned", float_atomics=False, cell_sort=True),
    "binned-float-cells-order": dict(method="atomic", splat="binned", float_atomics=True, cell_sort=True,
                                     sorted_copy=False),
    "direct-fixed": dict(method="atomic", splat="direct", float_atomics=False),
    "direct-float": dict(method="atomic", splat="direct", float_atomics=True),
    "raster": dict(method="raster"),
    "raster-gs": dict(method="raster", vertex_layer=False),
}
METHODS = list(VARIANTS)
FLOAT_EXT = "GL_NV_shader_atomic_float"


def make(gl, resolution, variant, **kw):
    """A GridFriction of one variant; skips float-atomic variants where the extension is missing."""
    spec = dict(VARIANTS[variant])
    if spec.get("float_atomics") and FLOAT_EXT not in gl.extensions:
        pytest.skip(f"{FLOAT_EXT} not available")
    method = spec.pop("method")
    return GridFriction(gl, resolution, method, **spec, **kw)


def is_float(gf):
    """Sums in float32 (float atomics or raster blending) rather than exact fixed point."""
    return gf.method == "raster" or gf.float_atomics


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
    gf = make(gl, R, method, pinned_mass=2.0)
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
    gf = make(gl, 12, method)
    gf.splat(pb, vb, len(p))
    g = gf.read_grid()
    m = ref.masses(p[:, 3])
    np.testing.assert_allclose(g["density"].sum(dtype=np.float64), m.sum(), rtol=2e-6)
    mom = (m[:, None] * v[:, :3]).sum(axis=0)
    np.testing.assert_allclose(g["momentum"].reshape(-1, 3).sum(axis=0, dtype=np.float64), mom,
                               rtol=0, atol=2e-5 * np.abs(m[:, None] * v[:, :3]).sum())
    gf.release()


def test_atomic_and_raster_agree_and_fixed_point_is_deterministic(gl):
    p, v = scene(2000, seed=7)
    grids = {}
    for variant in METHODS + ["binned-fixed-again"]:
        pb, vb = upload(gl, p, v)
        gf = make(gl, 16, variant.removesuffix("-again"))
        gf.splat(pb, vb, len(p))
        grids[variant] = gf.read_grid()
        gf.release()
    ref_grid = grids["direct-fixed"]
    for variant, g in grids.items():
        np.testing.assert_allclose(g["density"], ref_grid["density"], rtol=1e-6,
                                   atol=1e-6 * ref_grid["density"].max(), err_msg=variant)
    # fixed point: exact sums, so the binned (shared-memory) splat equals the direct one bit for bit
    # whatever the order it sorts by, and a second run equals the first
    for variant in ("binned-fixed", "binned-fixed-cells", "binned-fixed-again"):
        np.testing.assert_array_equal(grids[variant]["density"], ref_grid["density"])
        np.testing.assert_array_equal(grids[variant]["velocity"], ref_grid["velocity"])


@pytest.mark.parametrize("cell_sort", [False, True])
@pytest.mark.parametrize("variant", ["binned-fixed", "binned-float", "binned-float-run"])
@pytest.mark.parametrize("R,n,chunk,pinned_mass", [(16, 1, 2048, 1.0), (9, 257, None, 0.0), (16, 0, None, 1.0),
                                                   (64, 5000, 256, 1.0), (97, 20000, 1024, 0.0),
                                                   (129, 3000, None, 1.0)])
@pytest.mark.slow
def test_binned_splat_equals_direct(gl, variant, cell_sort, R, n, chunk, pinned_mass):
    """Tiles at the grid's far faces (R - 1 not a multiple of 8), chunks across several tiles,
    no particle, a single particle, counts that are not multiples of a work group, hot nodes (a
    clump of identical positions), NaN particles and massless pinned ones left out, and runs of
    consecutive particles along lines (strands), a few per cell; sorted by tile or by cell."""
    p, v = scene(max(n, 1), seed=R)                   # (n = 0: buffers of one particle, none splatted)
    if n > 100:
        p[: n // 10, :3] = p[0, :3]                   # 10% of the particles on one point
        p[n // 10: n // 10 + 3, :3] = np.nan          # not splatted by either
        # 20% in strands of 16 particles a fraction of a cell apart (several consecutive ones per cell)
        first, count = n // 2, n // 5 // 16 * 16
        rng = np.random.default_rng(R + 1)
        roots = rng.normal(size=(count // 16, 3)) * (0.3, 0.5, 0.2) + (0.1, 1.6, -0.05)
        dirs = rng.normal(size=(count // 16, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        steps = np.arange(16)[None, :, None] * (0.4 / (R - 1)) * dirs[:, None]
        p[first:first + count, :3] = (roots[:, None] + steps).reshape(-1, 3)
    direct = make(gl, R, "direct-" + variant.split("-")[1], pinned_mass=pinned_mass)
    if cell_sort and chunk and cell_splat_shared_bytes(chunk, "float" in variant) > _shared_limit(gl):
        chunk = None                                  # (llvmpipe's 32 KB: the longest chunk that fits)
    binned = make(gl, R, variant, chunk=chunk, cell_sort=cell_sort, pinned_mass=pinned_mass)
    assert binned.splat_schedule == "binned" and direct.splat_schedule == "direct"
    assert binned.cell_sort == cell_sort
    bounds = GridBounds(gl).set(np.nanmin(p[:, :3], axis=0) - 0.01, np.nanmax(p[:, :3], axis=0) + 0.01)
    finite = np.all(np.isfinite(p[:, :3]), axis=1)
    grids = []
    for gf, keep in ((direct, finite), (binned, slice(None))):   # the direct splat without the NaNs
        pb, vb = upload(gl, p[keep], v[keep])
        gf.splat(pb, vb, int(len(p[keep])) if n else 0, bounds)
        grids.append(gf.read_grid())
    if binned.float_atomics:
        scale = grids[0]["density"].max()
        np.testing.assert_allclose(grids[1]["density"], grids[0]["density"], rtol=0, atol=2e-6 * scale)
        np.testing.assert_allclose(grids[1]["momentum"], grids[0]["momentum"], rtol=0, atol=2e-5 * scale)
    else:
        np.testing.assert_array_equal(grids[1]["density"], grids[0]["density"])
        np.testing.assert_array_equal(grids[1]["velocity"], grids[0]["velocity"])
    # a second splat with the same object: the tile counters were reset by the scan
    pb, vb = upload(gl, p, v)
    binned.splat(pb, vb, n, bounds)
    np.testing.assert_allclose(binned.read_grid()["density"], grids[1]["density"], rtol=1e-6,
                               atol=1e-6 * grids[1]["density"].max())
    direct.release()
    binned.release()


def test_splat_defaults_and_large_grids(gl):
    gf = GridFriction(gl, 16)
    assert gf.splat_schedule == "binned"
    assert gf.float_atomics == (FLOAT_EXT in gl.extensions)
    gf.release()
    big = GridFriction(gl, 130)                 # more tiles than the binned histogram holds
    assert big.splat_schedule == "direct"
    big.release()
    with pytest.raises(UsageError):
        GridFriction(gl, 130, splat="binned")
    with pytest.raises(UsageError):
        GridFriction(gl, 16, splat="sorted")
    # the cell order is the binned splat's: nothing to order elsewhere
    for kw in (dict(resolution=130), dict(splat="direct"), dict(method="raster")):
        with pytest.raises(UsageError, match="cell_sort"):
            GridFriction(gl, **{"resolution": 16, **kw}, cell_sort=True)
    for chunk in (300, 256 * 33):                  # not a multiple of 256; past the 16-bit slots' default
        with pytest.raises(UsageError, match="cell_sort"):
            GridFriction(gl, 16, cell_sort=True, chunk=chunk)
    limit = _shared_limit(gl)
    for float_atomics in ((False, True) if FLOAT_EXT in gl.extensions else (False,)):
        # the default chunk: 256 x CELL_RUN, shortened until the splat's shared memory fits
        cells = GridFriction(gl, 129, cell_sort=True, float_atomics=float_atomics)
        assert cells.chunk % 256 == 0 and 256 <= cells.chunk <= 256 * CELL_RUN
        assert cell_splat_shared_bytes(cells.chunk, float_atomics) <= limit
        if is_software_renderer(gl):               # llvmpipe's loop limiter: short chunks
            assert cells.chunk == SOFTWARE_CELL_CHUNK
        else:
            assert cells.chunk == 256 * CELL_RUN or cell_splat_shared_bytes(cells.chunk + 256, float_atomics) > limit
        assert cells.num_tiles == 16 ** 3 and cells.uses_sorted_copy(1)
        cells.release()
    if cell_splat_shared_bytes(256 * 32, False) > limit:
        with pytest.raises(UsageError, match="shared memory"):
            GridFriction(gl, 16, cell_sort=True, float_atomics=False, chunk=256 * 32)
    # by default the splats that make the sorted copy walk their chunks in cell order, with float
    # sums only; the others keep the tile walk
    plain = GridFriction(gl, 16)
    assert plain.cell_sort is None and plain.chunk == CHUNK
    assert plain.copy_cell_sort == plain.aggregate
    assert plain.copy_chunk == (SOFTWARE_CELL_CHUNK if is_software_renderer(gl) else 256 * CELL_RUN) or not plain.aggregate
    assert not plain.uses_sorted_copy(1000) and plain.uses_sorted_copy(SORTED_COPY_MIN)
    plain.release()
    off = GridFriction(gl, 16, cell_sort=False)
    assert not off.copy_cell_sort and off.copy_chunk == CHUNK
    off.release()
    fixed = GridFriction(gl, 16, float_atomics=False)
    assert not fixed.copy_cell_sort
    fixed.release()


def test_clear_accumulator_on_the_gpu(gl):
    """The benchmark's explicit clear zeroes the accumulator with a dispatch, not a CPU map."""
    p, v = scene(500, seed=3)
    for variant in ("binned-fixed", "direct-float"):
        gf = make(gl, 8, variant)
        pb, vb = upload(gl, p, v)
        gf.accumulator.bind_to_storage_buffer(2)
        gf.accumulator.write(np.ones(gf.accumulator.size // 4, np.uint32).tobytes())
        gf.clear_accumulator()
        assert not np.frombuffer(gf.accumulator.read(), np.uint32).any()
        gf.release()


# ------------------------------------------------------------------ gather
@pytest.mark.parametrize("method", METHODS)
def test_friction_one_takes_grid_velocity(gl, method):
    R = 16
    p, v = scene(2000, seed=8)
    pb, vb = upload(gl, p, v)
    gf = make(gl, R, method)
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
    gf = make(gl, R, method)
    gf.apply(pb, vb, len(p), friction=0.3)
    lo, hi = gf.bounds.read()
    want, _, _ = ref.grid_friction(p, v, lo, hi, R, 0.3)
    np.testing.assert_allclose(read4(vb, len(p))[:, :3], want, rtol=0, atol=2e-5)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
def test_friction_zero_leaves_velocities(gl, method):
    p, v = scene(1000, seed=10)
    pb, vb = upload(gl, p, v)
    gf = make(gl, 16, method)
    gf.apply(pb, vb, len(p), friction=0.0)
    np.testing.assert_array_equal(read4(vb, len(p)), v)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("friction", [0.05, 0.5, 1.0])
def test_uniform_field_unchanged(gl, method, friction):
    p, v = scene(1500, seed=11)
    v[:, :3] = [0.3, -1.2, 2.5]
    pb, vb = upload(gl, p, v)
    gf = make(gl, 16, method)
    gf.apply(pb, vb, len(p), friction=friction)
    # float32 sums (float atomics, blending): V = sum(m w v) / sum(m w) to a few ulp of |v|
    atol = 5e-6 if is_float(gf) else 2e-6
    np.testing.assert_allclose(read4(vb, len(p))[:, :3], v[:, :3], rtol=0, atol=atol)
    gf.release()


@pytest.mark.parametrize("method", METHODS)
def test_shared_bounds_clamp_outside_particles(gl, method):
    """A fixed box smaller than the groom: particles outside are clamped onto it, as in the twin."""
    R = 8
    p, v = scene(800, seed=12)
    pb, vb = upload(gl, p, v)
    lo, hi = np.array([-0.2, 1.3, -0.2]), np.array([0.4, 1.9, 0.1])
    bounds = GridBounds(gl).set(lo, hi)
    gf = make(gl, R, method)
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
    # the options as a command line's table gives them (--set solver.grid_options.KEY=VALUE):
    # text, NaN and infinities refused in one line before anything is built
    for bad, words in ((dict(float_atomics="maybe"), "float_atomics must be true, false or None"),
                       (dict(sorted_copy=-5), "sorted_copy must be true"),
                       (dict(chunk=float("nan")), "chunk must be a whole number"),
                       (dict(chunk=float("inf")), "chunk must be a whole number"),
                       (dict(chunk=512.5), "chunk must be a whole number")):
        with pytest.raises(UsageError, match=words):
            GridFriction(gl, 8, **bad)
    gf = GridFriction(gl, 8)
    p, v = scene(10)
    pb, vb = upload(gl, p, v)
    with pytest.raises(UsageError):
        gf.apply(pb, vb, 10, friction=1.5)
    with pytest.raises(UsageError):
        gf.apply(pb, vb, 11, friction=0.5)
    gf.apply(pb, vb, 0, friction=0.5)      # no particles: a no-op
    gf.release()


def test_the_sorted_copy_is_chosen_by_size_and_made_only_when_used(gl):
    from mane.sim.grid_friction import SORTED_COPY_MIN

    p, v = scene(3000, seed=9)
    pb, vb = upload(gl, p, v)
    assert GridFriction(gl, 16, cell_sort=True).uses_sorted_copy(1)   # the cell sort turns it on
    gf = GridFriction(gl, 16, "atomic", splat="binned")
    assert not gf.uses_sorted_copy(len(p)) and gf.uses_sorted_copy(SORTED_COPY_MIN)
    gf.apply(pb, vb, len(p), friction=0.0)
    plain = gf.read_grid()
    assert gf._sorted is None and gf._copy_stages is None       # below the size: neither buffers nor programs
    gf.sorted_copy = True
    gf.apply(pb, vb, len(p), friction=0.0)
    copied = gf.read_grid()
    assert gf._sorted is not None and gf._sorted.size >= 32 * len(p)
    tol = 1e-6 if is_float(gf) else 0.0      # float atomics add in another order; fixed point is exact
    np.testing.assert_allclose(copied["density"], plain["density"], rtol=tol, atol=tol)
    np.testing.assert_allclose(copied["momentum"], plain["momentum"], rtol=1e-5 if tol else 0.0, atol=1e-5 if tol else 0.0)
    gf.release()


@pytest.mark.parametrize("cell_sort", [False, True])
def test_a_refused_sorted_copy_leaves_the_splat_usable(gl, monkeypatch, cell_sort):
    """Out of memory for the sorted copies: one GPUMemoryError, and the splat without them then
    works and gives the sums it gave before."""
    from mane.errors import GPUMemoryError
    from mane.gpu import buffers

    p, v = scene(3000, seed=4)
    pb, vb = upload(gl, p, v)
    gf = GridFriction(gl, 16, "atomic", splat="binned", cell_sort=cell_sort, sorted_copy=False)
    gf.apply(pb, vb, len(p), friction=0.0)
    before = gf.read_grid()

    def refuse(*args, **kwargs):
        raise GPUMemoryError("no room (test)")

    monkeypatch.setattr(buffers, "check_allocation", refuse)
    gf.sorted_copy = True
    with pytest.raises(GPUMemoryError):
        gf.apply(pb, vb, len(p), friction=0.0)
    monkeypatch.undo()
    gf.sorted_copy = False
    gf.apply(pb, vb, len(p), friction=0.0)
    after = gf.read_grid()
    tol = 1e-6 if is_float(gf) else 0.0
    np.testing.assert_allclose(after["density"], before["density"], rtol=tol, atol=tol)
    gf.release()


def test_long_chunks_keep_every_particle(gl):
    """The binned splat's longest chunk a CPU rasteriser takes (SOFTWARE_MAX_CHUNK) over particles
    spread across a 129^3 grid's 4,096 tiles keeps every particle's mass (llvmpipe's loop limiter
    dropped 37% of it in chunks of 8,192); longer chunks are refused there with one line."""
    from mane.gpu.context import is_software_renderer
    from mane.sim.grid_friction import SOFTWARE_MAX_CHUNK

    n = 8000
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(-1, 1, (n, 3)), np.ones(n)]).astype(np.float32)
    pb, vb = upload(gl, p, np.zeros((n, 4), np.float32))
    gf = GridFriction(gl, 129, "atomic", splat="binned", chunk=SOFTWARE_MAX_CHUNK, pinned_mass=1.0)
    gf.apply(pb, vb, n, friction=0.0)
    assert abs(float(gf.read_grid()["density"].sum()) - n) < 1e-3 * n
    gf.release()
    if is_software_renderer(gl):
        with pytest.raises(UsageError, match="CPU rasteriser"):
            GridFriction(gl, 129, "atomic", splat="binned", chunk=2 * SOFTWARE_MAX_CHUNK)


@pytest.mark.parametrize("cell_sort,sorted_copy", [(False, False), (False, True), (True, True)])
@pytest.mark.parametrize("R,n", [(16, 3001), (64, 20000), (9, 700)])
def test_sorted_slots_follow_the_tiles(gl, cell_sort, sorted_copy, R, n):
    """The tile sort itself, read back (the same with the cell-ordered splat, which orders only
    inside its chunks): the tiles of the particles in slot order are non-decreasing, the order is
    a permutation of the binned particles (no NaN, no massless pinned one), and each tile's start
    is the prefix sum of the tiles before it. Without the sorted copies the order is read from
    its buffer; with them (which the splat reads instead, the order left unwritten) it is
    recovered from the copies' rows, so the copies must hold each binned particle's position and
    velocity once, in tile order. The tiles are recomputed here from the positions, which sit
    well inside their cells, so a wrong tile or scan shows."""
    rng = np.random.default_rng(R + n)
    cells = R - 1
    cell = rng.integers(0, cells, size=(n, 3))
    cell[: n // 3] = cell[0]                         # a crowded cell: a run longer than a chunk
    p = np.zeros((n, 4), np.float32)
    p[:, :3] = (cell + rng.uniform(0.1, 0.9, size=(n, 3))) / cells   # the box [0, 1]^3
    p[:, 3] = rng.uniform(0.5, 4.0, n)
    p[::37, 3] = 0.0                                  # pinned, massless below: not binned
    p[5::101, :3] = np.nan                            # not binned
    v = rng.normal(size=(n, 4)).astype(np.float32)
    pb, vb = upload(gl, p, v)
    bounds = GridBounds(gl).set([0, 0, 0], [1, 1, 1])
    gf = GridFriction(gl, R, "atomic", splat="binned", cell_sort=cell_sort, sorted_copy=sorted_copy,
                      pinned_mass=0.0)
    row_of = {p[i].tobytes(): i for i in range(n)}    # the rows are distinct (random positions)
    binned = np.flatnonzero(np.all(np.isfinite(p[:, :3]), axis=1) & (p[:, 3] > 0))
    tile = cell // 8
    axis = -(-cells // 8)
    key = tile[:, 0] + axis * (tile[:, 1] + axis * tile[:, 2])
    T = gf.num_tiles
    assert T == axis ** 3
    for _ in range(2):                                # the second time the scan's cleared counters
        gf.splat(pb, vb, n, bounds)
        words = np.frombuffer(gf._order.read(), np.uint32)
        tiles = np.frombuffer(gf._tiles.read(), np.uint32)
        total = int(tiles[2 * T])
        assert total == len(binned)
        if sorted_copy:
            record = np.frombuffer(gf._sorted.read(), np.float32).reshape(-1, 8)[:total]
            order = np.array([row_of.get(r.tobytes(), -1) for r in record[:, :4].copy()])
            np.testing.assert_array_equal(record[:, 4:7], v[order, :3])
        else:
            order = words[n:n + total]
        assert np.array_equal(np.sort(order), binned)            # a permutation of the binned ones
        assert np.array_equal(words[binned], key[binned])         # the shader's tiles are these
        assert np.all(np.diff(key[order].astype(np.int64)) >= 0)  # sorted by them
        starts = tiles[T:2 * T + 1]
        want = np.concatenate([[0], np.cumsum(np.bincount(key[binned], minlength=T))])
        assert np.array_equal(starts, want)
        assert not tiles[:T].any()                                # counts cleared for the next step
        assert np.array_equal(tiles[2 * T + 1:3 * T + 1], want[1:])   # each cursor at its tile's end
    gf.release()


@pytest.mark.parametrize("float_atomics", [False, True])
@pytest.mark.parametrize("chunk", [256, 768, None])
def test_cell_order_keeps_every_particle_once(gl, float_atomics, chunk):
    """The cell-ordered walk of chunks that span several tile segments, of lengths that are not
    multiples of 256, with crowded cells (ranks past 256) and the cells of a strand's
    consecutive slots scattered over the tile: every particle summed once (a wrong scan or
    permutation drops or repeats some). Masses are powers of two apart per particle, so a
    particle lost or doubled changes the sums far beyond rounding; fixed point equals the direct
    splat bit for bit."""
    if float_atomics and FLOAT_EXT not in gl.extensions:
        pytest.skip(f"{FLOAT_EXT} not available")
    R = 33                                            # 4^3 tiles of 8^3 cells
    rng = np.random.default_rng(11)
    n = 9000
    cell = rng.integers(0, R - 1, size=(n, 3))
    cell[1000:3000] = cell[1000]                      # 2000 in one cell: ranks past 256 in a chunk
    cell[3000:3600] = (8, 8, 8)                       # a tile's first cell, the last one's next
    cell[3600:4200] = (7, 7, 7)
    p = np.zeros((n, 4), np.float32)
    p[:, :3] = (cell + rng.uniform(0.05, 0.95, size=(n, 3))) / (R - 1)
    p[:, 3] = 2.0 ** -rng.integers(0, 12, n)          # inverse masses 1 .. 2^-11
    p[::53, 3] = 0.0                                  # pinned (pinned_mass 1)
    v = np.zeros((n, 4), np.float32)
    v[:, :3] = rng.normal(size=(n, 3))
    pb, vb = upload(gl, p, v)
    bounds = GridBounds(gl).set([0, 0, 0], [1, 1, 1])
    grids = []
    for kw in (dict(splat="direct"), dict(splat="binned", cell_sort=True, chunk=chunk)):
        gf = GridFriction(gl, R, "atomic", float_atomics=float_atomics, **kw)
        gf.splat(pb, vb, n, bounds)
        grids.append(gf.read_grid())
        if kw["splat"] == "binned":
            assert gf.cell_sort and gf.chunk == (chunk or gf.chunk)
            starts = np.frombuffer(gf._tiles.read(), np.uint32)[gf.num_tiles:2 * gf.num_tiles + 1]
            edges = set(starts.tolist())
            spanning = sum(len({e for e in edges if c < e < c + gf.chunk}) > 0 for c in range(0, n, gf.chunk))
            assert spanning >= 2                     # chunks over several tile segments
        gf.release()
    direct, cells = grids
    if float_atomics:
        scale = direct["density"].max()
        np.testing.assert_allclose(cells["density"], direct["density"], rtol=1e-5, atol=1e-6 * scale)
        np.testing.assert_allclose(cells["momentum"], direct["momentum"], rtol=1e-4,
                                   atol=1e-5 * np.abs(direct["momentum"]).max())
    else:
        np.testing.assert_array_equal(cells["density"], direct["density"])
        np.testing.assert_array_equal(cells["momentum"], direct["momentum"])
