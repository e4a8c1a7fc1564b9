"""Every strand-solver kernel against its NumPy twin (src/mane/twins/sim.py)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from mane import Groom
from mane.sim import Capsule, Ellipsoid, SimSettings, Simulator, SolverTuning, Sphere, WindSettings, head_motion
from mane.sim.wind import gust_field
from mane.twins import sim as ref


def tune(sim, **changes) -> None:
    """Set the simulator's kernel choices (SimSettings.solver, a SolverTuning)."""
    sim.settings = replace(sim.settings, solver=replace(sim.settings.solver, **changes))


def switches(defines: dict) -> dict:
    """strand_solve.comp's defines as SolverTuning's switches (unnamed ones keep their defaults)."""
    names = {"CULL_PRIMS": "cull_prims"}
    return {names[k]: bool(v) for k, v in defines.items()}

pytestmark = pytest.mark.gpu

RTOL = 1e-5


def make_sim(gl, rest, settings=None, colliders=(), **kw):
    return Simulator(Groom.from_strands(list(rest)), colliders, settings or SimSettings(), ctx=gl, **kw)


def padded(sim, name):
    st = sim.state
    return st.read(name)[:, :3].astype(np.float64).reshape(st.num_strands, st.points_per_strand, 3)


def put(sim, name, arr):
    st = sim.state
    data = st.read(name)
    data[:, :3] = np.asarray(arr, dtype=np.float32).reshape(-1, 3)
    st.write(name, data)


def inv_mass(sim):
    st = sim.state
    return st.read("rest_positions")[:, 3].astype(np.float64).reshape(st.num_strands, st.points_per_strand)


def assert_close(gpu, cpu, scale=None):
    scale = float(np.abs(cpu).max()) if scale is None else scale
    err = float(np.abs(gpu - cpu).max())
    assert err <= RTOL * max(scale, 1e-3), f"max |gpu - twin| = {err:.3g} (scale {scale:.3g})"


def perturbed(rest, amount, seed):
    rng = np.random.default_rng(seed)
    x = rest + rng.normal(scale=amount, size=rest.shape)
    x[:, 0] = rest[:, 0]
    return x


HEAD = head_motion.about_pivot(head_motion.rotation((0.3, 1.0, 0.2), 0.4), (0.0, 0.9, 0.1))
HEAD[:3, 3] += (0.01, -0.02, 0.03)


@pytest.fixture
def rest():
    return ref.straight_strands(S=6, N=16, length=0.3, direction=(0.2, -0.3, 1.0))


def test_integrate_matches_twin(gl, rest):
    settings = SimSettings(damping=2.0, drag=1.5, global_shape_stiffness=0.3, global_shape_range=0.5,
                           wind=WindSettings(velocity=(2.0, 0.0, -1.0), gust=0.6, turbulence=0.4, seed=7),
                           max_speed=5.0)
    cols = [Sphere(center=(0.02, 0.95, 0.15), radius=0.05, mode="penalty", stiffness=3000.0),
            Capsule(a=(-0.1, 0.98, 0.25), b=(0.2, 0.98, 0.25), radius=0.03, mode="penalty", stiffness=800.0)]
    sim = make_sim(gl, rest, settings, cols)
    rng = np.random.default_rng(1)
    x = perturbed(rest, 0.01, 2)
    v = rng.normal(scale=1.0, size=rest.shape)
    v[0, 3] = (40.0, 0.0, 0.0)  # above max_speed: clamped
    put(sim, "positions", x)
    put(sim, "velocities", v)
    sim.state.time = 1.7
    sim.set_head_transform(HEAD)
    sim.state.head = HEAD
    prev0 = padded(sim, "prev_positions")
    h = 1 / 120
    assert sim.run_pass("integrate", sim.state, h)
    want_x, want_prev = ref.integrate(x, prev0, v, rest, inv_mass(sim), HEAD, h, settings, cols, 1.7)
    assert_close(padded(sim, "positions"), want_x)
    assert_close(padded(sim, "prev_positions"), want_prev)


def test_integrate_keeps_last_valid_prev_for_nan(gl, rest):
    sim = make_sim(gl, rest)
    x = rest.copy()
    x[2, 5] = np.nan
    put(sim, "positions", x)
    prev_before = padded(sim, "prev_positions")
    sim.run_pass("integrate", sim.state, 1 / 120)
    prev = padded(sim, "prev_positions")
    assert np.array_equal(prev[2, 5], prev_before[2, 5])
    assert np.all(np.isfinite(prev))


def test_wind_field_matches_twin():
    wind = WindSettings(velocity=(3.0, 0.5, 0.0), gust=0.8, turbulence=0.5, frequency=1.3, octaves=4, seed=99)
    roots = np.random.default_rng(0).uniform(-0.2, 0.2, size=(20, 3))
    strands = np.arange(20)
    for t in (0.0, 0.37, 5.2, 31.9):
        got = gust_field(wind, roots, strands, t)
        want = np.array([ref.wind_velocity(wind, s, roots[s].astype(np.float32).astype(np.float64), t)
                         for s in strands])
        assert np.allclose(got, want, atol=1e-4), (t, np.abs(got - want).max())
    # gusts change the wind over time and differ between strands, around the mean
    w = np.stack([gust_field(wind, roots, strands, t) for t in np.linspace(0, 20, 400)])
    assert w[..., 0].std() > 0.3
    assert abs(w[..., 0].mean() - 3.0) < 1.0


@pytest.mark.parametrize("local_k, bend_k", [(0.6, 0.0), (0.0, 0.7), (0.4, 0.5)])
def test_shape_matches_twin(gl, local_k, bend_k):
    rest = ref.helix_strands(S=3, N=16)
    settings = SimSettings(local_shape_stiffness=local_k, bending_stiffness=bend_k, shape_iterations=3)
    sim = make_sim(gl, rest, settings)
    x = perturbed(rest, 0.003, 3)  # segments are 2.5 cm: keep joints far from folding back
    x[:, 0] = ref.apply(HEAD, rest[:, 0])
    put(sim, "positions", x)
    sim.state.head = HEAD
    assert sim.run_pass("shape", sim.state, 1 / 120)
    want = ref.shape(x, inv_mass(sim), rest, HEAD, local_k, bend_k, 3)
    assert_close(padded(sim, "positions"), want)


@pytest.mark.parametrize("S, N", [(70, 16), (33, 64), (40, 3)])
@pytest.mark.slow
def test_shape_and_dftl_match_twins_across_work_groups(gl, S, N):
    """More strands than one work group, a last group that is partly empty, long strands
    (64 points), and a pinned particle mid-strand (it leads DFTL and stops the shape sweep's
    carried correction)."""
    rest = ref.helix_strands(S=S, N=N)
    settings = SimSettings(local_shape_stiffness=0.4, bending_stiffness=0.5, shape_iterations=2,
                           fused_strand_solve=False)  # the length pass alone
    sim = make_sim(gl, rest, settings)
    x = perturbed(rest, 0.002, 11)
    x[:, 0] = ref.apply(HEAD, rest[:, 0])
    st = sim.state
    rp = st.read("rest_positions")
    rp[5 * N + N // 2, 3] = 0.0                     # strand 5: a pinned particle in the middle
    st.write("rest_positions", rp)
    put(sim, "positions", x)
    st.head = HEAD
    assert sim.run_pass("shape", st, 1 / 120)
    want = ref.shape(x, inv_mass(sim), rest, HEAD, 0.4, 0.5, 2)
    assert_close(padded(sim, "positions"), want)
    y = perturbed(rest, 0.01, 12)
    y[:, 0] = x[:, 0]
    put(sim, "positions", y)
    sim.run_pass("length", st, 1 / 120)
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    want_x, want_d = ref.dftl(y, inv_mass(sim), seg, rest, HEAD)
    assert_close(padded(sim, "positions"), want_x)
    assert_close(padded(sim, "corrections"), want_d, scale=float(np.abs(want_x).max()))


def test_local_shape_keeps_and_restores_bind_pose(gl):
    """The rest pose under the head is a fixed point; repeated sweeps return to it."""
    rest = ref.helix_strands(S=2, N=16)
    sim = make_sim(gl, rest, SimSettings(local_shape_stiffness=1.0, shape_iterations=1))
    target = ref.apply(HEAD, rest)
    sim.state.head = HEAD
    put(sim, "positions", target)
    sim.run_pass("shape", sim.state, 1 / 120)
    assert_close(padded(sim, "positions"), target)
    x = perturbed(rest, 0.003, 4)
    x[:, 0] = target[:, 0]
    put(sim, "positions", x)
    sim.run_pass("shape", sim.state, 1 / 120)
    assert_close(padded(sim, "positions"), target)  # stiffness 1: one sweep rebuilds the bind pose


def test_dftl_matches_twin(gl, rest):
    sim = make_sim(gl, rest)
    tune(sim, keep_corrections=True)  # ... writing d_k for the check
    x = perturbed(rest, 0.02, 5)
    x[1, 4] = x[1, 3]  # a zero-length segment takes its rest direction
    put(sim, "positions", x)
    sim.state.head = HEAD
    sim.run_pass("length", sim.state, 1 / 120)
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    want_x, want_d = ref.dftl(x, inv_mass(sim), seg, rest, HEAD)
    assert_close(padded(sim, "positions"), want_x)
    assert_close(padded(sim, "corrections"), want_d, scale=float(np.abs(want_x).max()))
    assert sim.max_length_error() < 1e-4


@pytest.mark.parametrize("N, S, tether", [(16, 7, False), (20, 5, True), (64, 2, True), (2, 40, False)])
def test_pbd_matches_twin(gl, N, S, tether):
    rest = ref.straight_strands(S=S, N=N, length=0.25, direction=(0.0, -0.5, 1.0))
    settings = SimSettings(length_method="pbd", pbd_iterations=5, long_range_attachment=tether)
    sim = make_sim(gl, rest, settings)
    x = perturbed(rest, 0.015, 6)
    x[:, -1] += (0.0, -0.2, 0.1)  # stretched tips, for the tether
    put(sim, "positions", x)
    sim.run_pass("length", sim.state, 1 / 120)
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    arc = np.concatenate([np.zeros((S, 1)), np.cumsum(seg, axis=1)], axis=1)
    want = ref.pbd(x, inv_mass(sim), seg, 5, tether, arc)
    assert_close(padded(sim, "positions"), want)


def test_collide_matches_twin(gl):
    rest = ref.straight_strands(S=10, N=16, length=0.3, direction=(0.0, -1.0, 0.2), spacing=0.012,
                                origin=(-0.05, 1.0, 0.0))
    rot = head_motion.rotation((0.2, 0.1, 1.0), 0.7)
    rot[:3, 3] = (0.0, 0.85, 0.05)
    cols = [Sphere(center=(0.0, 0.8, 0.02), radius=0.04, friction=0.3),
            Ellipsoid(transform=rot, radii=(0.06, 0.03, 0.05), friction=0.0, margin=0.002),
            Capsule(a=(-0.1, 0.9, 0.03), b=(0.1, 0.92, 0.03), radius=0.02, friction=2.0),
            Sphere(center=(0.0, 0.75, 0.0), radius=0.2, mode="penalty")]  # ignored by this pass
    sim = make_sim(gl, rest, SimSettings(), cols)
    x = perturbed(rest, 0.01, 7)
    prev = x + np.random.default_rng(8).normal(scale=0.004, size=x.shape)
    put(sim, "positions", x)
    put(sim, "prev_positions", prev)
    want = ref.collide(x, prev, inv_mass(sim), cols, np.eye(4))
    moved = np.linalg.norm(want - x, axis=2) > 1e-6
    assert moved.sum() > 10, "the scene should put particles inside the colliders"
    sim.run_pass("collide", sim.state, 1 / 120)
    assert_close(padded(sim, "positions"), want)


def test_velocity_matches_twin(gl, rest):
    settings = SimSettings(dftl_damping=0.7, max_speed=3.0)
    sim = make_sim(gl, rest, settings)
    rng = np.random.default_rng(9)
    x, prev, d = (rest + rng.normal(scale=s, size=rest.shape) for s in (0.01, 0.01, 0.002))
    x[0, 5] += (0.1, 0, 0)  # fast: clamped
    put(sim, "positions", x)
    put(sim, "prev_positions", prev)
    put(sim, "corrections", d)
    h = 1 / 240
    sim.run_pass("velocity", sim.state, h)
    want = ref.velocity(x, prev, d, inv_mass(sim), h, 0.7, 3.0)
    assert_close(padded(sim, "velocities"), want)


@pytest.mark.parametrize("method, defines", [("dftl", {}), ("pbd", {}),
                                             ("dftl", {"CULL_PRIMS": 0})])
@pytest.mark.slow
def test_steps_match_twin(gl, method, defines):
    """k full steps of the GPU solver against k steps of the twin, from the same start (DFTL: the
    per-strand kernel's defaults, and without culling the primitives out of a strand's reach)."""
    # curly strands: with straight ones every joint's bending plane is float32 noise, which
    # the non-converged PBD amplifies step after step (a conditioning issue, not a bug)
    rest = ref.helix_strands(S=4, N=12, radius=0.03, pitch=0.1, turns=1.0, spacing=0.03)
    settings = SimSettings(length_method=method, pbd_iterations=6, damping=1.0, drag=0.5,
                           wind=WindSettings(velocity=(1.0, 0.0, 0.5), gust=0.3, turbulence=0.2),
                           local_shape_stiffness=0.01, bending_stiffness=0.2, shape_iterations=2,
                           global_shape_stiffness=0.05, global_shape_range=0.3,
                           long_range_attachment=method == "pbd")
    cols = [Sphere(center=(0.03, 0.895, -0.015), radius=0.025, friction=0.2),
            Capsule(a=(0.0, 0.95, -0.05), b=(0.1, 0.95, -0.05), radius=0.03, mode="penalty", stiffness=500.0)]
    sim = make_sim(gl, rest, settings, cols)
    tune(sim, **switches(defines))
    w = inv_mass(sim)
    assert max(c.depth(rest.reshape(-1, 3)).max() for c in cols) > -0.01  # close to the hair
    x, prev, v = rest.copy(), rest.copy(), np.zeros_like(rest)
    free = (rest.copy(), rest.copy(), np.zeros_like(rest))
    h, t = settings.dt, 0.0
    for _ in range(10):
        sim.step()
        x, prev, v = ref.step(x, prev, v, rest, w, np.eye(4), h, settings, cols, t)
        free = ref.step(*free, rest, w, np.eye(4), h, settings, cols[1:], t)
        t += h
    assert np.abs(free[0] - x).max() > 1e-3, "the sphere should have touched the hair"
    got = padded(sim, "positions")
    assert np.abs(got - rest).max() > 0.01, "the strands should have moved"
    assert_close(got, x, scale=float(np.abs(x).max()))
    # velocities are position differences over dt: their float32 error scales with |x| / dt
    assert_close(padded(sim, "velocities"), v, scale=float(np.abs(x).max()) / h)


# ---------------------------------------------------------------------- collisions in the sweeps
def head_scene(S=12, N=12, length=0.2, radius=0.1, center=(0.0, 1.6, 0.0)):
    """Strands from roots on a sphere's upper cap, first along the surface (tangent), so
    that gravity drapes them over it."""
    rng = np.random.default_rng(21)
    c = np.asarray(center)
    out = []
    for s in range(S):
        th, ph = rng.uniform(0.15, 1.0), rng.uniform(0, 2 * np.pi)
        n = np.array([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)])
        t = (n[1] * n - [0.0, 1.0, 0.0]) / np.sin(th)  # unit tangent pointing down the sphere
        d = 0.3 * n + t
        out.append(c + radius * n + np.linspace(0, length, N)[:, None] * d / np.linalg.norm(d))
    return np.array(out)


def sdf_params(sim, st=None):
    """The simulator's mesh colliders as the twin's dicts (at the state's last step)."""
    from mane.sim import MeshCollider

    st = st or sim.state
    meshes = [c for c in sim.colliders if isinstance(c, MeshCollider)]
    return [dict(values=c._sdf.values.astype(np.float64), lo=c._sdf.lo.astype(np.float32).astype(np.float64),
                 h=np.float32(c._sdf.h).astype(np.float64), world=w, prev_world=pw, margin=c.margin,
                 friction=c.friction) for c, w, pw in zip(meshes, st.mesh_worlds, st.mesh_prev_worlds)]


def collision_setup(gl, settings, mesh=True):
    """Strands over a head (a sphere and a mesh SDF just outside it, both riding on the head),
    a capsule and an ellipsoid in the hair, predicted positions pressed into all of them."""
    from mane.bench.sim_bench import head_mesh
    from mane.sim import MeshCollider

    rest = head_scene()
    x = ref.apply(HEAD_SMALL, rest)
    centre = ref.apply(HEAD_SMALL, np.array([0.0, 1.6, 0.0]))
    r = np.random.default_rng(5).uniform(0.095, 0.13, size=x.shape[:2])[..., None]
    x = centre + (x - centre) / np.linalg.norm(x - centre, axis=2, keepdims=True) * r
    x[:, 0] = ref.apply(HEAD_SMALL, rest[:, 0])

    def outside(s, k, dist):  # a point over particle k of strand s, dist from the centre
        u = x[s, k] - centre
        return centre + dist * u / np.linalg.norm(u)

    c6, c9 = outside(6, 6, 0.135), outside(9, 7, 0.14)
    cols = [Sphere(center=(0.0, 1.6, 0.0), radius=0.1, friction=0.3, follow_head=True),
            Capsule(a=c6 - (0.05, 0.0, 0.0), b=c6 + (0.05, 0.01, 0.0), radius=0.025, friction=0.5),
            Ellipsoid(transform=_at(*c9) @ head_motion.rotation((0, 0, 1), 0.3),
                      radii=(0.03, 0.035, 0.03), friction=0.0, margin=0.001)]
    if mesh:
        cols.append(MeshCollider(head_mesh(center=(0.0, 1.6, 0.0), radii=(0.105, 0.1, 0.105)), resolution=32,
                                 margin=0.002, friction=0.2, follow_head=True))
    sim = make_sim(gl, rest, settings, cols)
    st = sim.state
    st.head = HEAD_SMALL
    sim.upload_colliders(st)
    sim.upload_colliders(st)  # previous = current transforms
    prev = ref.apply(HEAD_SMALL, rest) + np.random.default_rng(6).normal(scale=0.002, size=rest.shape)
    put(sim, "positions", x)
    put(sim, "prev_positions", prev)
    return sim, rest, cols, x, prev


def _at(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


HEAD_SMALL = head_motion.about_pivot(head_motion.rotation((1.0, 0.0, 0.2), 0.15), (0.0, 1.45, 0.0))


def test_dftl_collides_inside_the_sweep(gl):
    """The length pass alone: DFTL with primitives and a mesh SDF inside its sweep, against
    the twin; lengths exact and no particle left inside at the same time."""
    sim, rest, cols, x, prev = collision_setup(gl, SimSettings(fused_strand_solve=False))
    w = inv_mass(sim)
    assert sim.run_pass("length")
    got = padded(sim, "positions")
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    want, want_d = ref.dftl(x, w, seg, rest, HEAD_SMALL, prev, cols[:3], sdf_params(sim))
    moved = np.linalg.norm(want - x, axis=2) > 1e-3
    assert moved.sum() > 20
    assert_close(got, want)
    assert_close(padded(sim, "corrections"), want_d, scale=float(np.abs(want).max()))
    assert sim.max_length_error() < 1e-5
    assert sim.max_penetration() < 2e-6
    depth_mesh = cols[3].margin - cols[3]._sdf.sample(ref.apply(np.linalg.inv(sim.state.mesh_worlds[0]),
                                                                got.reshape(-1, 3)))
    assert depth_mesh[w.reshape(-1) > 0].max() < 2e-4  # the SDF's own round-off: trilinear of a 32^3 grid


@pytest.mark.parametrize("iterations, pipeline, group", [(2, 1, 64), (2, 2, 64), (3, 2, 32), (5, 1, 128),
                                                       (5, 4, 64), (1, 4, 64)])
@pytest.mark.slow
def test_fused_strand_solve_matches_twin(gl, iterations, pipeline, group):
    """One kernel (integrate's prediction, shape sweeps pipelined, more of them through
    memory, DFTL with the collisions, velocities) against the twins of the separate passes,
    and against the separate passes on the GPU."""
    settings = SimSettings(local_shape_stiffness=0.3, bending_stiffness=0.4, shape_iterations=iterations,
                           dftl_damping=0.8, max_speed=10.0, damping=1.5, drag=1.2, global_shape_stiffness=0.01,
                           global_shape_range=0.4, wind=WindSettings(velocity=(1.5, 0.0, -0.5), gust=0.5, seed=3))
    settings = replace(settings, solver=SolverTuning(shape_pipeline=pipeline, strand_group_size=group,
                                                     fold_integrate=True))
    sim, rest, cols, x, prev = collision_setup(gl, settings)
    st = sim.state
    st.write("rest_positions", _pin_middle(st.read("rest_positions"), st.points_per_strand, strand=3))
    w = inv_mass(sim)
    h = 1 / 240
    # the step starts at prev with the velocity that takes it (about) to x, pressed into the colliders
    x, start0 = prev, x
    v = (start0 - x) / h
    v[2, 5] = (30.0, 0.0, 0.0)  # above max_speed: clamped in the prediction
    prev = x + np.random.default_rng(7).normal(scale=0.001, size=x.shape)
    for name, arr in (("positions", x), ("prev_positions", prev), ("velocities", v)):
        put(sim, name, arr)
    st.time = 0.4
    assert sim.folded_passes() == {"collide": "length", "sdf": "length", "shape": "length", "velocity": "length",
                                   "integrate": "length", "guard": "length"}
    assert sim.run_pass("length", st, h)
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    pred, start = ref.integrate(x, prev, v, rest, w, HEAD_SMALL, h, settings, cols[:3], 0.4)
    shaped = ref.shape(pred, w, rest, HEAD_SMALL, 0.3, 0.4, iterations)
    want, want_d = ref.dftl(shaped, w, seg, rest, HEAD_SMALL, start, cols[:3], sdf_params(sim))
    want_v = ref.velocity(want, start, want_d, w, h, 0.8, 10.0)
    got, got_v = padded(sim, "positions"), padded(sim, "velocities")
    assert_close(got, want)
    assert_close(padded(sim, "prev_positions"), start)
    assert_close(got_v, want_v, scale=float(np.abs(want).max()) / h)
    without_mesh = ref.dftl(shaped, w, seg, rest, HEAD_SMALL, start, cols[:3])[0]
    assert np.abs(without_mesh - want).max() > 1e-4  # the mesh SDF took part (3e-4 here; round-off ~1e-6)
    # the same with the separate passes
    sep = replace(settings, fused_strand_solve=False)
    sim.settings = sep
    for name, arr in (("positions", x), ("prev_positions", prev), ("velocities", v)):
        put(sim, name, arr)
    for name in ("integrate", "shape", "length", "velocity"):
        sim.run_pass(name, st, h)
    assert_close(padded(sim, "positions"), got)
    assert_close(padded(sim, "velocities"), got_v, scale=float(np.abs(want).max()) / h)
    # and fused without integrate (SolverTuning.fold_integrate False): integrate, then length
    sim.settings = settings
    tune(sim, fold_integrate=False)
    assert "integrate" not in sim.folded_passes()
    for name, arr in (("positions", x), ("prev_positions", prev), ("velocities", v)):
        put(sim, name, arr)
    for name in ("integrate", "length"):
        sim.run_pass(name, st, h)
    assert_close(padded(sim, "positions"), got)
    assert_close(padded(sim, "velocities"), got_v, scale=float(np.abs(want).max()) / h)


@pytest.mark.parametrize("defines", [{}, {"CULL_PRIMS": 0}])
@pytest.mark.slow
def test_strand_kernel_switches_match_twin(gl, defines):
    """The per-strand kernel with primitives out of a strand's reach culled or not, against
    the twin: the hair is pressed into a sphere, a capsule and an ellipsoid; two more capsules and
    an ellipsoid lie beyond the reach of every strand, or of some, from its root (culled)."""
    settings = SimSettings(local_shape_stiffness=0.2, bending_stiffness=0.3, shape_iterations=2, dftl_damping=0.7)
    sim, rest, cols, x, prev = collision_setup(gl, settings, mesh=False)
    reach = float(np.linalg.norm(np.diff(rest, axis=1), axis=2).sum(axis=1).max())
    root = ref.apply(HEAD_SMALL, rest[0, 0])
    far = [Capsule(a=root + (0.0, reach + 0.08, 0.0), b=root + (0.1, reach + 0.1, 0.0), radius=0.03),
           Ellipsoid(transform=_at(*(root + (reach + 0.2, 0.0, 0.0))), radii=(0.02, 0.05, 0.03)),
           Capsule(a=root + (0.0, -reach - 0.02, 0.0), b=root + (0.0, -reach - 0.3, 0.0), radius=0.025)]
    sim.colliders = sim.colliders + far
    sim.upload_colliders(sim.state)
    sim.upload_colliders(sim.state)
    tune(sim, **switches(defines))
    w = inv_mass(sim)
    h = 1 / 240
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    shaped = ref.shape(x, w, rest, HEAD_SMALL, 0.2, 0.3, 2)
    # and a sphere that only the tip of the most stretched strand reaches, nearly its length from
    # its root (culling it for that strand with a reach 3 cm short would lose the contact)
    tips = ref.dftl(shaped, w, seg, rest, HEAD_SMALL, prev, cols + far)[0][:, -1]
    extent = np.linalg.norm(tips - ref.apply(HEAD_SMALL, rest[:, 0]), axis=1)
    s = int(np.argmax(extent))
    near_tip = Sphere(center=tuple(tips[s] + (0.004, 0.0, 0.0)), radius=0.01)
    assert extent[s] - 0.014 > seg[s].sum() - 0.03
    sim.colliders = sim.colliders + [near_tip]
    sim.upload_colliders(sim.state)
    sim.upload_colliders(sim.state)
    assert sim.run_pass("length", sim.state, h)
    want, want_d = ref.dftl(shaped, w, seg, rest, HEAD_SMALL, prev, cols + far + [near_tip])
    assert np.linalg.norm(want[s, -1] - tips[s]) > 1e-3
    assert np.linalg.norm(want - shaped, axis=2).max() > 1e-3   # the colliders took part
    assert_close(padded(sim, "positions"), want)
    assert_close(padded(sim, "velocities"), ref.velocity(want, prev, want_d, w, h, 0.7, settings.max_speed),
                 scale=float(np.abs(want).max()) / h)


@pytest.mark.slow
def test_fused_integrate_penalty_and_nan(gl, rest):
    """The fused kernel's prediction with penalty colliders (integrate.comp's twin), and a
    non-finite start position: prev_positions keeps its last valid value."""
    settings = SimSettings(damping=2.0, drag=1.5, global_shape_stiffness=0.3, global_shape_range=0.5,
                           max_speed=5.0, local_shape_stiffness=0.0, bending_stiffness=0.0)
    cols = [Sphere(center=(0.02, 0.95, 0.15), radius=0.05, mode="penalty", stiffness=3000.0)]
    sim = make_sim(gl, rest, settings, cols)
    tune(sim, fold_integrate=True)
    assert sim.folded_passes()["integrate"] == "length"
    x = perturbed(rest, 0.01, 2)
    v = np.random.default_rng(1).normal(scale=1.0, size=rest.shape)
    put(sim, "positions", x)
    put(sim, "velocities", v)
    sim.state.head = HEAD
    prev0 = padded(sim, "prev_positions")
    h = 1 / 120
    sim.run_pass("length", sim.state, h)
    w = inv_mass(sim)
    pred, start = ref.integrate(x, prev0, v, rest, w, HEAD, h, settings, cols, 0.0)
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    want, want_d = ref.dftl(pred, w, seg, rest, HEAD, start)
    assert_close(padded(sim, "positions"), want)
    assert_close(padded(sim, "prev_positions"), start)
    want_v = ref.velocity(want, start, want_d, w, h, settings.dftl_damping, settings.max_speed)
    assert_close(padded(sim, "velocities"), want_v, scale=float(np.abs(want).max()) / h)
    x[2, 5] = np.nan
    put(sim, "positions", x)
    before = padded(sim, "prev_positions")
    sim.run_pass("length", sim.state, h)
    after = padded(sim, "prev_positions")
    assert np.array_equal(after[2, 5], before[2, 5]) and np.all(np.isfinite(after))


def _pin_middle(rp, N, strand):
    rp = rp.copy()
    rp[strand * N + N // 2, 3] = 0.0
    return rp


def test_pbd_collides_between_iterations(gl):
    settings = SimSettings(length_method="pbd", pbd_iterations=6)
    sim, rest, cols, x, prev = collision_setup(gl, settings)
    assert sim.run_pass("length")
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    want = ref.pbd(x, inv_mass(sim), seg, 6, False, None, prev, cols[:3], sdf_params(sim), head=HEAD_SMALL)
    assert_close(padded(sim, "positions"), want)
    # the iterations end with the lengths: the last solve's correction may leave a particle
    # slightly inside, far less than the collision setup's depth
    assert sim.max_length_error() < 1e-3
    assert sim.max_penetration() < 2e-3
