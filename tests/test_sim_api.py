"""The Simulator's interface: settings, time stepping, snapshots, haircut, robustness, CLI."""
from __future__ import annotations

import importlib.util
import json
import math
from dataclasses import replace

import numpy as np
import pytest

import mane
from mane import Groom, GPUMemoryError, UsageError
from mane.sim import (Capsule, MeshCollider, SimSettings, Simulator, SolverTuning, Sphere, WindSettings,
                      estimate_bytes, head_motion, iteration_stiffness)
from mane.sim.settings import MAX_DT
from mane.twins import sim as ref

pytestmark = pytest.mark.gpu


def groom_of(rest, **kw):
    return Groom.from_strands(list(rest), **kw)


@pytest.fixture
def rest():
    return ref.straight_strands(S=6, N=16, length=0.3, direction=(0.2, -0.5, 1.0))


def padded(sim, state=None):
    st = state or sim.state
    return sim.positions(st).astype(np.float64).reshape(st.num_strands, st.points_per_strand, 3)


# ---------------------------------------------------------------------- settings
def test_settings_validate():
    with pytest.raises(UsageError):
        SimSettings(length_method="verlet")
    with pytest.raises(UsageError):
        SimSettings(dt=0.5)
    with pytest.raises(UsageError):
        SimSettings(local_shape_stiffness=1.5)
    with pytest.raises(UsageError):
        SimSettings(gravity=(0, float("nan"), 0))
    with pytest.raises(UsageError):
        WindSettings(frequency=0)
    docs = SimSettings.field_docs()
    assert "m/s^2" in docs["gravity"] and "1/s" in docs["damping"] and docs["dt"]


def test_iteration_stiffness():
    for k in (0.0, 0.1, 0.5, 0.99, 1.0):
        for n in (1, 2, 8):
            kit = iteration_stiffness(k, n)
            assert math.isclose(1 - (1 - kit) ** n, k, abs_tol=1e-12)


def test_settings_can_change_between_steps(gl, rest):
    sim = Simulator(groom_of(rest), settings=SimSettings(gravity=(0, 0, 0)), ctx=gl)
    sim.step()
    assert np.abs(padded(sim) - rest).max() < 1e-6
    sim.settings = replace(sim.settings, gravity=(0, -9.81, 0))
    sim.step()
    assert np.abs(padded(sim) - rest).max() > 1e-5
    with pytest.raises(UsageError):
        sim.settings = {"dt": 0.01}


# ---------------------------------------------------------------------- time
def test_advance_runs_fixed_steps(gl, rest):
    sim = Simulator(groom_of(rest), settings=SimSettings(dt=1 / 120, max_substeps=4), ctx=gl)
    assert sim.advance(1 / 60) == 2
    assert sim.advance(1 / 300) == 0  # accumulates
    assert sim.advance(1 / 300) == 0
    assert sim.advance(1 / 300) == 1  # 3/300 = 1/100 >= 1/120
    assert math.isclose(sim.state.accumulator, 3 / 300 - 1 / 120, abs_tol=1e-9)
    assert sim.advance(1.0) == 4  # clamped to max_substeps, the rest dropped
    assert sim.state.accumulator == 0.0
    assert sim.state.steps == 7
    assert math.isclose(sim.state.time, 7 / 120)
    with pytest.raises(UsageError):
        sim.advance(-1)


def test_step_clamps_dt_and_substeps(gl, rest):
    sim = Simulator(groom_of(rest), settings=SimSettings(substeps=3), ctx=gl)
    sim.step(10.0)
    assert math.isclose(sim.state.time, MAX_DT)
    assert sim.state.steps == 3
    with pytest.raises(UsageError):
        sim.step(float("nan"))


def test_snapshot_restore_reset(gl, rest):
    sim = Simulator(groom_of(rest), [Sphere(center=(0.02, 0.9, 0.1), radius=0.05)], ctx=gl)
    for _ in range(5):
        sim.step()
    snap = sim.snapshot()
    for _ in range(5):
        sim.step()
    a = sim.positions()
    sim.restore(snap)
    assert sim.state.steps == 5
    for _ in range(5):
        sim.step()
    assert np.array_equal(sim.positions(), a)
    sim.reset()
    assert np.allclose(padded(sim), rest, atol=1e-7)
    assert sim.state.time == 0 and sim.kinetic_energy() == 0.0


def test_two_states_side_by_side(gl, rest):
    sim = Simulator(groom_of(rest), ctx=gl)
    other = sim.new_state()
    sim.set_head_transform(head_motion.nod(0.3, pivot=(0, 0.9, 0)), state=other)
    for _ in range(10):
        sim.step()
        sim.step(state=other)
    alone = Simulator(groom_of(rest), ctx=gl)
    for _ in range(10):
        alone.step()
    assert np.array_equal(sim.positions(), alone.positions())
    assert not np.array_equal(sim.positions(other), alone.positions())
    assert sim.max_root_error(other) < 2e-6


def test_state_buffers_are_bindable_and_callable(gl, rest):
    import moderngl

    sim = Simulator(groom_of(rest), ctx=gl)
    st = sim.state
    assert isinstance(st.positions, moderngl.Buffer)
    assert st.positions.size == st.num_particles * 16
    assert st.positions().shape == (st.num_particles, 3)
    assert np.array_equal(st.positions(), sim.positions())
    assert st.velocities().shape == (st.num_particles, 3)


def test_resamples_non_uniform_grooms(gl):
    strands = [np.stack([np.zeros(n), np.linspace(1, 0.8, n), np.zeros(n)], 1) + (0.01 * i, 0, 0)
               for i, n in enumerate((5, 9, 30, 80))]
    sim = Simulator(Groom.from_strands(strands), ctx=gl)
    assert sim.state.points_per_strand == 16 and sim.groom.uniform_count == 16
    sim = Simulator(Groom.from_strands(strands), ctx=gl, points_per_strand=8)
    assert sim.state.points_per_strand == 8
    with pytest.raises(UsageError):
        Simulator(Groom.from_strands(strands), ctx=gl, points_per_strand=65)


# ---------------------------------------------------------------------- haircut
def test_haircut_shortens_strands(gl, rest):
    sim = Simulator(groom_of(rest), settings=SimSettings(damping=3.0), ctx=gl)
    L = 0.3
    scale = np.linspace(0.4, 1.0, 6)
    sim.set_length_scale(scale)
    for _ in range(60):
        sim.step()
    p = padded(sim)
    arc = np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1)
    assert np.allclose(arc, L * scale, rtol=1e-3)
    assert sim.max_length_error() < 1e-4
    sim.set_length_scale(0.5)
    for _ in range(10):
        sim.step()
    arc = np.linalg.norm(np.diff(padded(sim), axis=1), axis=2).sum(axis=1)
    assert np.allclose(arc, 0.5 * L, rtol=1e-3)
    assert np.all(np.isfinite(padded(sim)))
    with pytest.raises(UsageError):
        sim.set_length_scale(1.5)
    sim.set_length_scale(1.0)
    for _ in range(5):
        sim.step()
    arc = np.linalg.norm(np.diff(padded(sim), axis=1), axis=2).sum(axis=1)
    assert np.allclose(arc, L, rtol=1e-3)


# ---------------------------------------------------------------------- robustness
@pytest.mark.parametrize("where", ["positions", "velocities", "prev_positions"])
@pytest.mark.parametrize("method", ["pbd", "dftl"])   # the guard's own pass; the fused solve's
def test_nan_injection_is_recovered(gl, rest, where, method):
    settings = SimSettings(length_method=method, local_shape_stiffness=0.1)
    sim = Simulator(groom_of(rest), settings=settings, ctx=gl)
    clean = Simulator(groom_of(rest), settings=settings, ctx=gl)
    for _ in range(5):
        sim.step()
        clean.step()
    data = sim.state.read(where)
    data[2 * 16 + 7, :3] = np.nan
    data[4 * 16 + 3, 1] = np.inf
    sim.state.write(where, data)
    sim.step()
    clean.step()
    p = padded(sim)
    assert np.all(np.isfinite(p)) and np.all(np.isfinite(sim.velocities()))
    if where == "prev_positions":
        assert sim.nan_recoveries == 0  # the next step overwrites them: harmless
        assert np.array_equal(p, padded(clean))
    else:
        assert sim.nan_recoveries == 2  # strands 2 and 4, back to their last valid state
        untouched = [0, 1, 3, 5]
        assert np.array_equal(p[untouched], padded(clean)[untouched])
        assert sim.state.read("guard")[1] == 5  # the largest recovered strand + 1
    for _ in range(5):
        sim.step()
    assert np.all(np.isfinite(sim.positions()))


def test_nan_with_no_valid_state_goes_back_to_rest(gl, rest):
    sim = Simulator(groom_of(rest), ctx=gl)
    sim.set_head_transform(head_motion.shake(0.4, pivot=(0, 0.9, 0)))
    sim.step()
    for name in ("positions", "prev_positions"):
        data = sim.state.read(name)
        data[3 * 16:4 * 16, :3] = np.nan
        sim.state.write(name, data)
    sim.step()
    assert sim.nan_recoveries == 1
    assert np.allclose(padded(sim)[3], ref.apply(sim.state.head, rest[3]), atol=1e-6)
    assert np.all(sim.velocities()[3 * 16:4 * 16] == 0)


def test_absurd_values_are_recovered(gl, rest):
    sim = Simulator(groom_of(rest), ctx=gl)
    sim.step()
    data = sim.state.read("positions")
    data[16 + 9, :3] += (50.0, 0.0, 0.0)  # 50 m away from its root
    sim.state.write("positions", data)
    sim.settings = replace(sim.settings, length_method="pbd", pbd_iterations=1)
    sim.step()
    assert sim.nan_recoveries == 1
    assert np.abs(padded(sim)[1] - rest[1]).max() < 0.05


def test_nan_guard_can_be_off(gl, rest):
    sim = Simulator(groom_of(rest), settings=SimSettings(nan_guard=False), ctx=gl)
    data = sim.state.read("positions")
    data[20, 0] = np.nan
    sim.state.write("positions", data)
    sim.step()
    assert sim.nan_recoveries == 0
    assert not np.all(np.isfinite(sim.positions()))


def test_too_large_groom_is_refused_before_allocating(gl, rest, monkeypatch):
    import mane.sim.state as state_module

    sizes = estimate_bytes(6, 16)
    assert sizes["positions"] == 6 * 16 * 16
    monkeypatch.setattr(state_module, "_buffer_limit", lambda ctx: 1024)
    made = []
    real_buffer = type(gl).buffer

    def counting_buffer(self, *a, **kw):
        made.append(1)
        return real_buffer(self, *a, **kw)

    monkeypatch.setattr(type(gl), "buffer", counting_buffer)
    with pytest.raises(GPUMemoryError, match="MiB"):
        Simulator(groom_of(rest), ctx=gl)
    assert not made


# ---------------------------------------------------------------------- colliders and helpers
def test_colliders_follow_the_head(gl, rest):
    ball = Sphere(center=(0.02, 0.95, 0.12), radius=0.04, follow_head=True)
    sim = Simulator(groom_of(rest), [ball], settings=SimSettings(damping=2.0), ctx=gl)
    m = head_motion.rotation((0, 1, 0), 0.6)
    sim.set_head_transform(m)
    for _ in range(20):
        sim.advance(1 / 60)
    assert sim.max_penetration() < 1e-5
    assert np.allclose(ball.world_transform(sim.state.head)[:3, 3], m[:3, :3] @ (0.02, 0.95, 0.12))


def test_collider_validation():
    with pytest.raises(UsageError):
        Sphere(radius=-1)
    with pytest.raises(UsageError):
        Capsule(mode="sticky")
    with pytest.raises(UsageError):
        Sphere(transform=np.diag([2.0, 2.0, 2.0, 1.0]))
    with pytest.raises(UsageError):
        Simulator(Groom.from_strands([np.zeros((2, 3)) + (0, 0, 0), np.array([[0, 0, 0], [0, 1, 0]])]),
                  colliders=["sphere"])


def test_hair_hair_passes_run_or_warn(gl, rest):
    settings = SimSettings(friction=0.2, volume=True, grid_resolution=16)
    sim = Simulator(groom_of(rest), settings=settings, ctx=gl)
    for _ in range(3):
        sim.step()
    assert np.all(np.isfinite(sim.positions()))
    from importlib.util import find_spec

    if find_spec("mane.sim.grid_friction") is None:
        assert any("friction" in w for w in sim.warnings)
    if find_spec("mane.sim.flip") is None:
        assert any("volume" in w for w in sim.warnings)


def test_mesh_collider_runs_or_warns(gl):
    from mane.mesh import Mesh

    # a closed box under the hair: strands fall onto it
    v = np.array([[x, y, z] for x in (-0.2, 0.2) for y in (0.6, 0.8) for z in (-0.2, 0.4)], float)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    box = Mesh(v, f)
    rest = ref.straight_strands(S=4, N=12, length=0.3, direction=(0, 0, 1), origin=(0.0, 0.9, 0.0))
    sim = Simulator(groom_of(rest), [MeshCollider(box, resolution=24, follow_head=False)],
                    settings=SimSettings(damping=2.0), ctx=gl)
    for _ in range(60):
        sim.step()
    assert np.all(np.isfinite(sim.positions()))
    assert padded(sim)[:, :, 1].min() > 0.8 - 0.01  # resting on the box, not through it


@pytest.mark.slow
def test_profiling_reports_pass_times(gl, rest):
    sim = Simulator(groom_of(rest), [Sphere(center=(0, 0.9, 0.1), radius=0.03)],
                    settings=SimSettings(local_shape_stiffness=0.1), ctx=gl, profile=True)
    for _ in range(3):
        sim.step()
    times = sim.pass_times()
    folded = sim.folded_passes()  # their work is timed under the pass that does it
    assert folded == {"shape": "length", "collide": "length", "sdf": "length", "velocity": "length",
                      "guard": "length"}
    for name in ("integrate", "shape", "length", "collide", "velocity", "guard"):
        assert (name in times and times[name] >= 0) != (name in folded)
    sim.settings = replace(sim.settings, fused_strand_solve=False)
    for _ in range(2):
        sim.step()
    times = sim.pass_times()
    assert set(sim.folded_passes()) == {"collide", "sdf"}
    for name in ("shape", "velocity", "guard"):
        assert times[name] >= 0


# ---------------------------------------------------------------------- head motion
def test_head_motion_presets_are_rigid():
    for name in ("none", "nod", "shake", "turn"):
        f = head_motion.preset(name, pivot=(0, 1.5, 0))
        for t in (0.0, 0.3, 1.1, 2.9):
            m = f(t)
            r = m[:3, :3]
            assert np.allclose(r.T @ r, np.eye(3)) and np.isclose(np.linalg.det(r), 1)
            assert np.allclose(m @ [0, 1.5, 0, 1], [0, 1.5, 0, 1])  # the pivot stays
    with pytest.raises(UsageError):
        head_motion.preset("spin")
    a, b = head_motion.rotation((0, 1, 0), 0.0), head_motion.rotation((0, 1, 0), 1.0)
    assert np.allclose(head_motion.interpolate(a, b, 0.5), head_motion.rotation((0, 1, 0), 0.5))


# ---------------------------------------------------------------------- command line
def test_cli_simulate(tmp_path, rest):
    from mane.app.cli import main

    src = tmp_path / "hair.npz"
    mane.save(groom_of(rest), src)
    out, stats = tmp_path / "anim.npz", tmp_path / "stats.json"
    assert main(["simulate", str(src), "--seconds", "0.2", "--fps", "20", "--points", "8",
                 "--out", str(out), "--stats", str(stats), "--motion", "shake", "--wind", "1,0,0"]) == 0
    s = json.loads(stats.read_text())
    for key in ("passes", "steps", "renderer", "max_length_error", "max_root_error",
                "max_penetration", "nan_recoveries"):
        assert key in s
    assert s["steps"] == 24 and s["max_length_error"] < 1e-4 and s["max_root_error"] < 1e-5
    assert "integrate" in s["passes"]
    with np.load(out) as z:
        assert z["frames"].shape == (4, 6 * 8, 3)
        assert np.all(np.isfinite(z["frames"]))
    usd = tmp_path / "anim.usda"
    rc = main(["simulate", str(src), "--seconds", "0.1", "--fps", "20", "--points", "8", "--out", str(usd)])
    if importlib.util.find_spec("pxr") is None:   # usd-core (a dependency) missing: a clear error
        assert rc == 2
    else:
        assert rc == 0
        assert usd.stat().st_size > 0
    assert main(["simulate", str(src), "--out", str(tmp_path / "x.abc")]) == 2


def _shaken(sims, steps, start=0):
    for j in range(start, start + steps):
        for sim in sims:
            sim.set_head_transform(head_motion.shake(j / 30, pivot=(0, 0.9, 0)))
            sim.step()


@pytest.mark.parametrize("method", ["atomic", "raster"])
def test_folds_match_the_separate_passes(gl, rest, method):
    """substep's folds (SolverTuning.fold_gather: friction's gather deferred to the next step's
    integrate; fold_bounds: the grid box's reduction in the length pass; fold_guard: the NaN
    guard in the length pass) give the steps of the passes run one after the other, whether the
    deferred gather is applied by the next integrate or settled by reading the velocities."""
    settings = SimSettings(friction=0.3, grid_resolution=16, grid_method=method, local_shape_stiffness=0.1)
    separate = replace(settings, solver=SolverTuning(fold_gather=False, fold_bounds=False, fold_guard=False))
    sims = [Simulator(groom_of(rest), [Sphere(center=(0, 0.9, 0.1), radius=0.03)], settings=s, ctx=gl)
            for s in (settings, separate)]
    a, b = sims
    assert a._defer_gather() and a._bounds_in_length() and a._guard_in_length()
    assert not (b._defer_gather() or b._bounds_in_length() or b._guard_in_length())
    assert a.folded_passes()["guard"] == "length" and "guard" not in b.folded_passes()
    _shaken(sims, 1)
    boxes = [np.concatenate(sim._grid.own_bounds.read()) for sim in sims]  # the same box, bit for bit
    assert np.array_equal(*boxes) and np.all(boxes[0][3:] > boxes[0][:3])
    assert a.state.pending_friction == pytest.approx(0.3) and b.state.pending_friction is None
    _shaken(sims, 5, 1)   # each step's integrate applies the last one's gather
    for start in (6, 9):
        scale = float(np.abs(b.velocities()).max())
        assert np.allclose(a.positions(), b.positions(), rtol=0, atol=1e-6)
        assert np.allclose(a.velocities(), b.velocities(), rtol=0, atol=1e-5 * scale)
        assert a.state.pending_friction is None   # reading settled it
        _shaken(sims, 3, start)   # after a settled gather the next integrate has none to apply


def test_deferred_gather_with_two_states(gl, rest):
    """One simulator stepping two states in turn (one friction grid) gives each the steps of a
    simulator of its own: a state's deferred gather runs before the other's splat overwrites
    the grid; a new grid resolution settles it first too. The splat accumulates in fixed point:
    float atomics add in the GPU's order, which differs run to run (an H200 then differs by
    ~1e-6 m/s after six steps; llvmpipe adds in order and has no float atomics)."""
    settings = SimSettings(friction=0.3, grid_resolution=16, local_shape_stiffness=0.1,
                           solver=SolverTuning(grid_options={"float_atomics": False}))
    sphere = [Sphere(center=(0, 0.9, 0.1), radius=0.03)]
    shared = Simulator(groom_of(rest), sphere, settings=settings, ctx=gl)
    other = shared.new_state()
    alone = [Simulator(groom_of(rest), sphere, settings=settings, ctx=gl) for _ in range(2)]
    for j in range(6):
        if j == 3:
            for sim in (shared, *alone):
                sim.settings = replace(settings, grid_resolution=20)
        for k, st in enumerate((shared.state, other)):
            head = head_motion.shake((j + 2 * k) / 30, pivot=(0, 0.9, 0))
            shared.set_head_transform(head, state=st)
            shared.step(state=st)
            alone[k].set_head_transform(head)
            alone[k].step()
    for st, sim in zip((shared.state, other), alone):
        assert np.allclose(st.positions(), sim.positions(), rtol=0, atol=1e-6)
        assert np.allclose(st.velocities(), sim.velocities(), rtol=0, atol=1e-6)


def test_grid_options_turn_the_cell_sort_on(gl, rest):
    """SolverTuning.grid_options reaches the friction grid: its cell-sorted splat (fixed point,
    exact sums whatever the order) gives the steps of the default tile-sorted one bit for bit."""
    sims = []
    for options in ({"float_atomics": False}, {"float_atomics": False, "cell_sort": True}):
        settings = SimSettings(friction=0.3, grid_resolution=16, local_shape_stiffness=0.1,
                               solver=SolverTuning(grid_options=options))
        sims.append(Simulator(groom_of(rest), settings=settings, ctx=gl))
    _shaken(sims, 4)
    assert [sim.friction_grid.cell_sort for sim in sims] == [None, True]
    assert np.array_equal(sims[0].positions(), sims[1].positions())
    assert np.array_equal(sims[0].velocities(), sims[1].velocities())


def test_folded_guard_recovers_before_the_grid_sees_nan(gl, rest):
    """The length pass's guard (fold_guard) resets a strand made NaN before the friction grid is
    splatted, so no NaN spreads to its neighbours: exactly one recovery, the strand's free
    particles back at their start-of-step positions, every other strand as in a clean run."""
    settings = SimSettings(friction=0.3, grid_resolution=16, local_shape_stiffness=0.1)
    sims = [Simulator(groom_of(rest), settings=settings, ctx=gl) for _ in range(2)]
    _shaken(sims, 4)
    sim, clean = sims
    before = padded(sim)
    data = sim.state.read("velocities")
    data[2 * 16 + 7, :3] = np.nan
    sim.state.write("velocities", data)
    clean.velocities()   # settle its gather too: the same arithmetic as the one written back
    _shaken(sims, 1, 4)
    assert sim.nan_recoveries == 1
    p = padded(sim)
    assert np.array_equal(p[2, 1:], before[2, 1:])   # its root follows the head
    assert np.allclose(p[2, 0], padded(clean)[2, 0], rtol=0, atol=1e-6)
    others = [0, 1, 3, 4, 5]
    assert np.allclose(p[others], padded(clean)[others], rtol=0, atol=1e-6)
    assert np.all(np.isfinite(sim.velocities()))


def test_mat4_follows_a_matrix_changed_in_place():
    """The head's uniform is kept per matrix value, never per array object."""
    from mane.sim.simulator import _mat4

    m = np.eye(4)
    assert _mat4(m) == tuple(np.eye(4).T.reshape(-1))
    m[0, 3] = 0.25                     # the same array, moved
    assert _mat4(m)[12] == 0.25        # column-major: the translation is the fourth column
    assert _mat4(m) is _mat4(m.copy())   # one tuple per value
