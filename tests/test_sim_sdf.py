"""MeshSDF: baking (sign, distance), sampling, GPU collisions, and solids in the FLIP grid."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from mane.errors import UsageError
from mane.mesh import Mesh
from mane.sim.sdf import MeshSDF, bake_sdf
from sdf_bake_v1 import closest_points_on_triangles, near_samples

pytestmark = pytest.mark.gpu


def exact_mesh_distance(points, vertices, faces):
    """Brute force: unsigned distance from each point to every triangle."""
    tris = np.asarray(vertices, np.float64)[np.asarray(faces)]
    out = np.empty(len(points))
    for i, p in enumerate(np.asarray(points, np.float64)):
        P = np.broadcast_to(p, (len(tris), 3))
        cp = closest_points_on_triangles(P, tris[:, 0], tris[:, 1], tris[:, 2])
        out[i] = np.linalg.norm(cp - p, axis=1).min()
    return out


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(subdivisions=3, radius=0.5)


@pytest.fixture(scope="module")
def sphere_sdf(gl, sphere):
    return MeshSDF.bake(gl, Mesh(sphere.vertices, sphere.faces), resolution=32, padding=0.1)  # metres


def nodes_of(sdf):
    return sdf.lo + np.indices(sdf.shape).reshape(3, -1).T * sdf.h


def test_closest_point_regions():
    a, b, c = np.array([[0.0, 0, 0]]), np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]])
    cases = {(-1, -1, 1): (0, 0, 0), (2, -0.5, 0): (1, 0, 0), (0.5, -1, 3): (0.5, 0, 0),
             (-1, 2, 0): (0, 1, 0), (-1, 0.5, 0): (0, 0.5, 0), (1, 1, 0): (0.5, 0.5, 0),
             (0.2, 0.3, -2): (0.2, 0.3, 0)}
    for p, want in cases.items():
        got = closest_points_on_triangles(np.array([p], float), a, b, c)[0]
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_near_samples_covers_every_node_within_the_query_bound():
    """The earlier bake (tests/sdf_bake_v1.py, the reference of test_sim_sdf_bake.py) queried
    only the nodes ``near_samples`` marks: every node within 2.5 h of a sample (brute force) must
    be among them, and the mark must not be the whole grid."""
    rng = np.random.default_rng(2)
    shape, lo, h = (23, 17, 20), np.array([-0.3, 0.1, 0.2]), 0.05
    pts = lo + rng.uniform(0.0, 1.0, (40, 3)) * (np.array(shape) - 1) * h
    pts[:4] = lo + np.array([[0, 0, 0], [22, 16, 19], [0, 16, 0], [21.999, 0.001, 10.5]]) * h  # box edges
    nodes = lo + np.indices(shape).reshape(3, -1).T * h
    dist = np.linalg.norm(nodes[:, None] - pts[None], axis=2).min(axis=1)
    mark = near_samples(pts, lo, h, shape, 2).reshape(-1)
    assert mark[dist <= 2.5 * h].all()
    assert not mark.all()


def test_sphere_sign_and_distance(sphere_sdf, sphere):
    nodes = nodes_of(sphere_sdf)
    values = sphere_sdf.values.reshape(-1)
    analytic = np.linalg.norm(nodes, axis=1) - 0.5
    h = sphere_sdf.h
    far = np.abs(analytic) > h
    np.testing.assert_array_equal(values[far] < 0, analytic[far] < 0)
    # facets of a 3-times subdivided icosphere lie up to ~0.005 inside the sphere
    assert np.abs(values - analytic).max() < h + 0.006
    # against the exact distance to the mesh itself, at random points (trilinear sampling)
    rng = np.random.default_rng(0)
    pts = rng.uniform(sphere_sdf.lo, sphere_sdf.hi, size=(150, 3))
    exact = exact_mesh_distance(pts, sphere.vertices, sphere.faces)
    sign = np.where(np.linalg.norm(pts, axis=1) < 0.49, -1, 1)      # facets lie within 0.005 of r = 0.5
    got = sphere_sdf.sample(pts)
    clear = exact > 0.02
    np.testing.assert_array_equal(np.sign(got[clear]), sign[clear])
    assert np.abs(np.abs(got) - exact).max() < h


def test_nodes_match_exact_mesh_distance(sphere_sdf, sphere):
    rng = np.random.default_rng(1)
    idx = rng.integers(0, sphere_sdf.values.size, 200)
    nodes = nodes_of(sphere_sdf)[idx]
    exact = exact_mesh_distance(nodes, sphere.vertices, sphere.faces)
    got = np.abs(sphere_sdf.values.reshape(-1)[idx])
    assert np.all(got >= exact - 1e-5)                 # never too small
    assert np.abs(got - exact).max() < 0.5 * sphere_sdf.h


def test_box_non_cubic_grid(gl):
    ext = np.array([0.4, 0.8, 0.2])
    box = trimesh.creation.box(extents=ext)
    sdf = MeshSDF.bake(gl, (box.vertices, box.faces), resolution=24, padding=0.08)
    assert sdf.shape[1] == 24 and sdf.shape[0] < 24 and sdf.shape[2] < sdf.shape[0]
    nodes = nodes_of(sdf)
    q = np.abs(nodes) - ext / 2
    analytic = np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)
    values = sdf.values.reshape(-1)
    far = np.abs(analytic) > sdf.h
    np.testing.assert_array_equal(values[far] < 0, analytic[far] < 0)
    assert np.abs(values - analytic).max() < sdf.h
    np.testing.assert_allclose(sdf.sample(nodes[:50]), values[:50], atol=1e-6)


def test_procedural_head_sign(gl):
    from mane.grooming.head import default_head, head_sdf

    head = default_head(subdivisions=3, relax_rounds=5)
    sdf = MeshSDF.bake(gl, head, resolution=32)
    nodes = nodes_of(sdf)
    analytic = head_sdf(nodes)
    values = sdf.values.reshape(-1)
    clear = np.abs(analytic) > 2 * sdf.h
    assert (values < 0).sum() > 500
    np.testing.assert_array_equal(values[clear] < 0, analytic[clear] < 0)


def test_sample_outside_box_adds_distance(sphere_sdf):
    far_point = np.array([[5.0, 0.0, 0.0]])
    assert abs(sphere_sdf.sample(far_point)[0] - 4.5) < sphere_sdf.h


# ------------------------------------------------------------------ collisions
def shell(n=2000, seed=0, inner=0.3, outer=0.7):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    p = np.zeros((n, 4), np.float32)
    p[:, :3] = d * rng.uniform(inner, outer, n)[:, None]
    p[:, 3] = 1.0
    p[::25, 3] = 0.0
    q = p.copy()
    q[:, :3] += rng.normal(size=(n, 3)) * 0.01
    return p, q


def rigid(angle=0.4, t=(0.1, -0.2, 0.05)):
    m = np.eye(4)
    c, s = np.cos(angle), np.sin(angle)
    m[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    m[:3, 3] = t
    return m


def to_world(m, p):
    out = p.copy()
    out[:, :3] = p[:, :3] @ m[:3, :3].T + m[:3, 3]
    return out


@pytest.mark.parametrize("friction", [0.0, 0.6, 50.0])
def test_collide_pushes_out_to_margin_and_matches_twin(gl, sphere_sdf, friction):
    p, q = shell(seed=2)
    T = rigid()
    pw, qw = to_world(T, p), to_world(T, q)
    pb, qb = gl.buffer(pw.tobytes()), gl.buffer(qw.tobytes())
    margin = 0.01
    sphere_sdf.collide(pb, qb, len(p), T, margin, friction, prev_transform=T)
    out = np.frombuffer(pb.read(), np.float32).reshape(-1, 4)
    want = sphere_sdf.collide_numpy(pw, qw, T, margin, friction)
    np.testing.assert_allclose(out, want, atol=2e-5)
    inv = np.linalg.inv(T)
    d = sphere_sdf.sample(out[:, :3] @ inv[:3, :3].T + inv[:3, 3])
    free = p[:, 3] > 0
    assert d[free].min() >= margin - 1e-4                 # nobody deeper than the margin
    pinned = ~free
    np.testing.assert_array_equal(out[pinned], pw[pinned])
    clear = free & (sphere_sdf.sample(p[:, :3]) >= margin)
    np.testing.assert_array_equal(out[clear], pw[clear])   # particles clear of the mesh untouched


def test_collide_friction_is_coulomb(gl, sphere_sdf):
    margin = 0.01
    r = 0.5 + margin * 0.5                                    # inside the margin
    prev = np.array([[0.0, r, 0.0, 1.0]], np.float32)
    cur = np.array([[0.05, r - 0.002, 0.0, 1.0]], np.float32)  # slid along +x, a little inward
    depth = margin - sphere_sdf.sample(cur[:, :3])[0]
    outs = {}
    for friction in (0.0, 1.0, 100.0):
        pb, qb = gl.buffer(cur.tobytes()), gl.buffer(prev.tobytes())
        sphere_sdf.collide(pb, qb, 1, np.eye(4), margin, friction, prev_transform=np.eye(4))
        outs[friction] = np.frombuffer(pb.read(), np.float32)[:3]
        np.testing.assert_allclose(outs[friction], sphere_sdf.collide_numpy(cur, prev, None, margin, friction)[0, :3],
                                   atol=2e-6)
        assert sphere_sdf.sample(outs[friction][None])[0] >= margin - 1e-4
    assert outs[0.0][0] > 0.045                                   # no friction: it keeps sliding
    assert abs(outs[0.0][0] - outs[1.0][0] - depth) < 0.2 * depth  # kinetic: slowed by ~ friction * depth
    assert abs(outs[100.0][0]) < 0.005                            # static: it stays where it was


def test_collide_follows_moving_head(gl, sphere_sdf):
    """A particle carried rigidly with the head is not dragged by friction."""
    margin = 0.01
    local = np.array([[0.0, 0.5 + 0.5 * margin, 0.0, 1.0]], np.float32)
    T0, T1 = rigid(0.0, (0, 0, 0)), rigid(0.3, (0.2, 0.1, 0.0))
    prev, cur = to_world(T0, local), to_world(T1, local)
    pb, qb = gl.buffer(cur.tobytes()), gl.buffer(prev.tobytes())
    sphere_sdf.collide(pb, qb, 1, T1, margin, 1.0, prev_transform=T0)
    out = np.frombuffer(pb.read(), np.float32)[:3]
    inv = np.linalg.inv(T1)
    back = out @ inv[:3, :3].T + inv[:3, 3]
    np.testing.assert_allclose(back[[0, 2]], 0.0, atol=1e-5)          # no tangential drag
    assert abs(sphere_sdf.sample(back[None])[0] - margin) < 1e-4        # pushed to the margin


def test_collide_with_a_state_object(gl, sphere_sdf):
    class State:
        pass

    p, q = shell(n=300, seed=3)
    st = State()
    st.positions, st.prev_positions = gl.buffer(p.tobytes()), gl.buffer(q.tobytes())
    st.num_particles = len(p)
    sphere_sdf.collide(st, np.eye(4), 0.0, 0.0)
    out = np.frombuffer(st.positions.read(), np.float32).reshape(-1, 4)
    assert sphere_sdf.sample(out[p[:, 3] > 0, :3]).min() >= -1e-4
    with pytest.raises(UsageError):
        sphere_sdf.collide(st, np.eye(4), 0.0, -1.0)


def test_flip_solid_cells_from_sdf(gl, sphere_sdf):
    from mane.gpu.bounds import GridBounds
    from mane.sim.flip import SOLID, FlipVolume
    from mane.sim.flip_cpu import flip_numpy

    p, _ = shell(n=2500, seed=4, inner=0.52, outer=0.75)
    rng = np.random.default_rng(5)
    v = np.zeros_like(p)
    v[:, :3] = rng.normal(size=(len(p), 3))
    T = rigid(0.2, (0.05, 0.0, 0.0))
    pw = to_world(T, p)
    flip = FlipVolume(gl, 12)
    bounds = GridBounds(gl).set([-0.8, -0.8, -0.8], [0.9, 0.8, 0.8])
    pb, vb = gl.buffer(pw.tobytes()), gl.buffer(v.tobytes())
    info = flip.apply(pb, vb, len(p), 1 / 60, 0.9, bounds=bounds, solid=sphere_sdf, solid_transform=T)
    st = flip.read_state()
    new, cinfo = flip_numpy(pw, v, 1 / 60, 12, 0.9, bounds=bounds.read(), solid=sphere_sdf,
                            solid_transform=T, return_state=True)
    np.testing.assert_array_equal(st["markers"], cinfo["markers"])
    assert (st["markers"] == SOLID).sum() > 8
    solid = st["markers"] == SOLID
    padded = np.pad(solid, 1)
    for a in range(3):      # faces touching a solid cell carry the solid's velocity (0)
        lo_sl = [slice(1, 13)] * 3
        hi_sl = [slice(1, 13)] * 3
        lo_sl[a] = slice(0, 13)
        hi_sl[a] = slice(1, 14)
        touching = padded[tuple(lo_sl)] | padded[tuple(hi_sl)]
        assert np.all(st["u"][a][touching] == 0)
    out = np.frombuffer(vb.read(), np.float32).reshape(-1, 4)
    np.testing.assert_allclose(out[:, :3], new, atol=1e-4 * np.abs(new).max())
    assert info["residual"] <= 1e-5
    flip.release()


def test_bad_bake_arguments(gl, sphere):
    with pytest.raises(UsageError):
        bake_sdf(sphere.vertices, sphere.faces, resolution=2)
    with pytest.raises(UsageError):
        bake_sdf(sphere.vertices, sphere.faces, padding=-1)
