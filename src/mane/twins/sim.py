"""NumPy twins of the strand solver's kernels, written from the equations.

Arrays are float64 and padded: (S, N, 3) positions, (S, N) inverse masses. Each function
is one compute pass of ``mane.sim.simulator``; ``step`` chains them in the simulator's
order. They are deliberately plain (loops where loops are clearer) and share no code
with the shaders or with ``mane.sim``'s CPU helpers, except reading collider parameters.
"""
from __future__ import annotations

import math

import numpy as np


# ---------------------------------------------------------------------- small maths
def apply(m, p):
    m = np.asarray(m, dtype=np.float64)
    return p @ m[:3, :3].T + m[:3, 3]


def axis_angle(axis, angle):
    """3x3 rotation (Rodrigues) about unit axis by angle."""
    x, y, z = axis
    K = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def rotation_from_x_to(u):
    """Smallest rotation taking e_x to unit u."""
    e = np.array([1.0, 0.0, 0.0])
    c = float(np.clip(u @ e, -1.0, 1.0))
    if c < -1.0 + 1e-6:
        return np.diag([-1.0, -1.0, 1.0])
    axis = np.cross(e, u)
    s = np.linalg.norm(axis)
    if s < 1e-15:
        return np.eye(3)
    return axis_angle(axis / s, math.atan2(s, c))


def turn_toward(a, b, f):
    """Rotation by the fraction f of the angle from vector a to vector b."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s = np.linalg.norm(axis)
    if s < 1e-9:
        if a @ b > 0:
            return np.eye(3)
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        s = np.linalg.norm(axis)
    return axis_angle(axis / s, f * math.atan2(np.linalg.norm(np.cross(a, b)), a @ b))


def root_frame(t):
    """Bind frame at a root whose first segment points along unit t (the solver's convention:
    x = t, y = normalize(helper x t) with helper z, or x when |t_z| > 0.9, z = x cross y)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(t[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
    y = np.cross(helper, t)
    y /= np.linalg.norm(y)
    return np.stack([t, y, np.cross(t, y)], axis=1)


def bind_frames(rest):
    """Per strand: root frame R0 (3x3) and reference vectors ref[k] (segment k-1 -> k in the
    frame carried to segment k-2; ref[0] unused)."""
    S, N, _ = rest.shape
    R0 = np.zeros((S, 3, 3))
    refs = np.zeros((S, N, 3))
    for s in range(S):
        d0 = rest[s, 1] - rest[s, 0]
        n0 = np.linalg.norm(d0)
        t = d0 / n0 if n0 > 1e-12 else np.array([0.0, -1.0, 0.0])
        F = root_frame(t)
        R0[s] = F
        for k in range(N - 1):
            d = rest[s, k + 1] - rest[s, k]
            refs[s, k + 1] = F.T @ d
            L = np.linalg.norm(d)
            if L > 1e-12:
                u = F.T @ (d / L)
                F = F @ rotation_from_x_to(u / np.linalg.norm(u))
    return R0, refs


def finite(p):
    return np.all(np.isfinite(p), axis=-1)


# ---------------------------------------------------------------------- colliders
def collider_params(c, head):
    """(world 4x4, kind, radii+margin (3,), half-height, mode, friction, stiffness)."""
    world = c.world_transform(head)
    if c.kind == 1:
        radii = np.asarray(c.radii, dtype=np.float64)
    else:
        radii = np.full(3, float(c.radius))
    h = float(np.linalg.norm(np.subtract(c.b, c.a))) / 2 if c.kind == 2 else 0.0
    return world, c.kind, radii + c.margin, h, c.mode, c.friction, c.stiffness


def local_depth(p, kind, radii, h):
    """depth (> 0 inside), local outward normal, local surface point of one local point."""
    if kind == 1:
        u = p / radii
        lu = np.linalg.norm(u)
        direction = u / lu if lu > 1e-12 else np.array([0.0, 1.0, 0.0])
        s = radii * direction
        n = s / radii**2
        n /= np.linalg.norm(n)
        d = np.linalg.norm(s - p)
        return (d if lu < 1 else -d), n, s
    q = np.zeros(3)
    if kind == 2:
        q[1] = min(max(p[1], -h), h)
    d = p - q
    dist = np.linalg.norm(d)
    n = d / dist if dist > 1e-12 else np.array([0.0, 1.0, 0.0])
    return radii[0] - dist, n, q + n * radii[0]


# ---------------------------------------------------------------------- wind
def _pcg(v):
    v = np.uint64(v) & np.uint64(0xFFFFFFFF)
    m = np.uint64(0xFFFFFFFF)
    state = (v * np.uint64(747796405) + np.uint64(2891336453)) & m
    word = (((state >> ((state >> np.uint64(28)) + np.uint64(4))) ^ state) * np.uint64(277803737)) & m
    return int((word >> np.uint64(22)) ^ word)


def _lattice(i, seed):
    h = _pcg((i & 0xFFFFFFFF) ^ _pcg(seed))
    return (h >> 8) * (2.0 / 16777215.0) - 1.0


def _noise(tau, seed):
    f = math.floor(tau)
    t = tau - f
    s = t * t * (3 - 2 * t)
    a, b = _lattice(int(f), seed), _lattice(int(f) + 1, seed)
    return a + (b - a) * s


def _fbm(tau, seed, octaves):
    total, amp, norm = 0.0, 1.0, 0.0
    for o in range(octaves):
        total += amp * _noise(tau * 2.0**o, (seed + o * 1013) & 0xFFFFFFFF)
        norm += amp
        amp *= 0.5
    return total / norm


def wind_velocity(wind, strand, root, t):
    U = np.asarray(wind.velocity, dtype=np.float64)
    speed = np.linalg.norm(U)
    direction = U / speed if speed > 0 else np.zeros(3)
    tau = wind.frequency * (t - root @ direction / max(speed, 0.5))
    tau += wind.jitter * ((_pcg((strand + 0x9E3779B9) & 0xFFFFFFFF) >> 8) / 16777216.0)
    seed = int(wind.seed) % 2**32
    n = [_fbm(tau, (seed + j * 7919) & 0xFFFFFFFF, wind.octaves) for j in range(4)]
    return U * (1 + wind.gust * n[0]) + wind.turbulence * np.array(n[1:])


# ---------------------------------------------------------------------- the passes
def integrate(x, prev, v, rest, w, head, dt, settings, colliders=(), time=0.0):
    """Forces, prediction, pinned follicles, global shape. Returns (x, prev, v_unused)."""
    S, N, _ = x.shape
    new_prev = np.where(finite(x)[..., None], x, prev)
    target = apply(head, rest)
    out = x.copy()
    g = np.asarray(settings.gravity)
    damp = math.exp(-settings.damping * dt)
    params = [collider_params(c, head) for c in colliders]
    for s in range(S):
        root = target[s, 0]
        wind = np.zeros(3)
        if settings.drag > 0 and settings.wind.active:
            wind = wind_velocity(settings.wind, s, root, time)
        for k in range(N):
            if w[s, k] == 0:
                out[s, k] = target[s, k]
                continue
            a = g.copy()
            if settings.drag > 0:
                a += settings.drag * (wind - v[s, k])
            for world, kind, radii, h, mode, mu, stiff in params:
                if mode != "penalty":
                    continue
                pl = (x[s, k] - world[:3, 3]) @ world[:3, :3]
                depth, n, _ = local_depth(pl, kind, radii, h)
                if depth > 0:
                    a += stiff * depth * (world[:3, :3] @ n)
            vv = v[s, k] * damp + dt * a
            sp = np.linalg.norm(vv)
            if sp > settings.max_speed:
                vv *= settings.max_speed / sp
            p = x[s, k] + dt * vv
            if settings.global_shape_stiffness > 0 and k / (N - 1) <= settings.global_shape_range + 1e-9:
                p += settings.global_shape_stiffness * (target[s, k] - p)
            out[s, k] = p
    return out, new_prev


def per_iteration(k, n):
    return 1.0 if k >= 1 else 1.0 - (1.0 - k) ** (1.0 / n)


def shape(x, w, rest, head, local_k, bend_k, iterations):
    """Local shape (bind frames carried root to tip; each joint turns and stretches the
    strand below it toward the bind pose) and bending (a joint bent beyond its rest angle
    is unbent in its plane, the strand below following), Gauss-Seidel."""
    S, N, _ = x.shape
    R0, refs = bind_frames(rest)
    seg_rest = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    e0, e1 = np.diff(rest, axis=1)[:, :-1], np.diff(rest, axis=1)[:, 1:]
    bend_rest = np.arctan2(np.linalg.norm(np.cross(e0, e1), axis=2), np.einsum("snk,snk->sn", e0, e1))
    kl, kb = per_iteration(local_k, iterations), per_iteration(bend_k, iterations)
    H = np.asarray(head)[:3, :3]
    p = x.copy()
    for s in range(S):
        for _ in range(iterations):
            if local_k > 0:
                F = H @ R0[s]
                for k in range(N - 1):
                    if w[s, k + 1] > 0:
                        a = p[s, k + 1] - p[s, k]
                        b = F @ refs[s, k + 1]
                        R = turn_toward(a, b, kl)
                        La = np.linalg.norm(a)
                        stretch = R @ a * (kl * (np.linalg.norm(b) / La - 1.0))
                        # the joint moves everything below it rigidly, up to the next pinned particle
                        j = k + 1
                        while j < N and w[s, j] > 0:
                            p[s, j] = p[s, k] + R @ (p[s, j] - p[s, k]) + stretch
                            j += 1
                    d = p[s, k + 1] - p[s, k]
                    L = np.linalg.norm(d)
                    if seg_rest[s, k] > 1e-12 and L > 1e-12:
                        u = F.T @ (d / L)
                        F = F @ rotation_from_x_to(u / np.linalg.norm(u))
            if bend_k > 0:
                for k in range(1, N - 1):
                    if w[s, k + 1] == 0:
                        continue
                    e0, a = p[s, k] - p[s, k - 1], p[s, k + 1] - p[s, k]
                    n = np.cross(e0, a)
                    sn = np.linalg.norm(n)
                    if min(np.linalg.norm(e0), np.linalg.norm(a)) <= 1e-12 or sn <= 1e-9 * np.linalg.norm(e0) * np.linalg.norm(a):
                        continue
                    excess = math.atan2(sn, e0 @ a) - bend_rest[s, k - 1]
                    if excess <= 0:  # unilateral: only joints bent beyond rest
                        continue
                    R = axis_angle(n / sn, -kb * excess)
                    j = k + 1
                    while j < N and w[s, j] > 0:
                        p[s, j] = p[s, k] + R @ (p[s, j] - p[s, k])
                        j += 1
    return p


def back_to_length(a, l, p, q, n):
    """Particle at distance l from its leader a after a collision moved it from p to q (outward
    normal n): nearest q on the plane through q normal to n, else toward q."""
    ha = (a - q) @ n
    if abs(ha) < l:
        c = a - ha * n
        u = q - c
        lu = np.linalg.norm(u)
        if not lu > 1e-6 * l:
            u = p - c
            u = u - (u @ n) * n
            lu = np.linalg.norm(u)
        if lu > 1e-12:
            return c + math.sqrt(l * l - ha * ha) * u / lu
    f = q - a
    lf = np.linalg.norm(f)
    return a + l * f / lf if lf > 1e-12 else q


def dftl(x, w, seg_len, rest, head, prev=None, colliders=(), sdfs=(), prev_worlds=None, contact_iterations=2):
    """Follow-the-leader with the collisions inside the sweep: each particle is placed at its
    rest length from its leader, then (up to ``contact_iterations`` times while inside a
    collider) projected out and put back at its length on the contact's tangent plane.
    Returns (positions, corrections d = final - predicted - collision pushes)."""
    S, N, _ = x.shape
    p = x.copy()
    d = np.zeros_like(x)
    H = np.asarray(head)[:3, :3]
    for s in range(S):
        for k in range(1, N):
            if w[s, k] == 0:
                continue
            r = p[s, k] - p[s, k - 1]
            L = np.linalg.norm(r)
            if L > 1e-12:
                u = r / L
            else:
                u = H @ (rest[s, k] - rest[s, k - 1])
                u = u / np.linalg.norm(u)
            a, l = p[s, k - 1], seg_len[s, k - 1]
            new = a + l * u
            push = np.zeros(3)
            for _ in range(contact_iterations if (colliders or sdfs) else 0):
                q, n, moved = project_out(new, prev[s, k], colliders, head, sdfs, prev_worlds)
                if not moved:
                    break
                push += q - new
                new = back_to_length(a, l, new, q, n)
            d[s, k] = new - x[s, k] - push
            p[s, k] = new
    return p, d


def pbd(x, w, seg_len, iterations, tether=False, arc=None, prev=None, colliders=(), sdfs=(), prev_worlds=None,
        head=None, alpha_tilde=0.0):
    """XPBD distance constraints C_j = |p_{j+1} - p_j| - l_j. Each iteration: every free
    particle projected out of the colliders unless its root lies deeper inside than the
    particle's rest arc length; the whole chain's linearised system
    (J W J^T + alpha~ I) dlambda = -(C + alpha~ lambda) solved exactly (dense here),
    dp = W J^T dlambda; with alpha~ = 0 one exact pairwise projection of the segments from even
    k, then odd k; then the tether."""
    S, N, _ = x.shape
    p = x.copy()
    lam = np.zeros((S, N - 1))
    if arc is None:
        arc = np.concatenate([np.zeros((S, 1)), np.cumsum(seg_len, axis=1)], axis=1)

    def project(s, a):
        b = a + 1
        wsum = w[s, a] + w[s, b]
        d = p[s, b] - p[s, a]
        L = np.linalg.norm(d)
        if wsum <= 0 or L <= 1e-12:
            return
        C = L - seg_len[s, a]
        p[s, a] += w[s, a] / wsum * C * d / L
        p[s, b] -= w[s, b] / wsum * C * d / L

    for _ in range(iterations):
        if colliders or sdfs:
            for s in range(S):
                for k in range(N):
                    if w[s, k] > 0:
                        q, _, moved = project_out(p[s, k], prev[s, k], colliders, head, sdfs, prev_worlds)
                        if moved:
                            r = project_out(p[s, 0], p[s, 0], colliders, head, sdfs, prev_worlds)[0]
                            if np.linalg.norm(r - p[s, 0]) <= arc[s, k]:
                                p[s, k] = q
        for s in range(S):
            d = p[s, 1:] - p[s, :-1]
            L = np.linalg.norm(d, axis=1)
            n = np.where(L[:, None] > 1e-12, d / np.maximum(L, 1e-300)[:, None], 0.0)
            C = L - seg_len[s]
            J = np.zeros((N - 1, N, 3))     # dC_j / dp_i
            for j in range(N - 1):
                J[j, j], J[j, j + 1] = -n[j], n[j]
            Jf = J.reshape(N - 1, 3 * N)
            W = np.repeat(w[s], 3)
            A = (Jf * W) @ Jf.T + alpha_tilde * np.eye(N - 1)
            rhs = -(C + alpha_tilde * lam[s])
            dead = ~(np.diag(A) > 0)
            A[dead, :], A[:, dead] = 0.0, 0.0
            A[dead, dead], rhs[dead] = 1.0, 0.0
            dl = np.linalg.solve(A, rhs)
            lam[s] += dl
            p[s] += (W * (Jf.T @ dl)).reshape(N, 3)
        if alpha_tilde == 0:
            for parity in (0, 1):
                for s in range(S):
                    for a in range(parity, N - 1, 2):
                        project(s, a)
        if tether:
            for s in range(S):
                for k in range(1, N):
                    if w[s, k] == 0:
                        continue
                    d = p[s, k] - p[s, 0]
                    L = np.linalg.norm(d)
                    if L > arc[s, k] and L > 1e-12:
                        p[s, k] = p[s, 0] + d * arc[s, k] / L
    return p


def collide(x, prev, w, colliders, head, prev_worlds=None):
    """Projection colliders with Coulomb friction on the displacement relative to them: every
    free particle through ``project_out`` (no SDFs)."""
    S, N, _ = x.shape
    p = x.copy()
    for s in range(S):
        for k in range(N):
            if w[s, k] != 0:
                p[s, k] = project_out(p[s, k], prev[s, k], colliders, head, (), prev_worlds)[0]
    return p


def project_out(p, x0, colliders, head, sdfs=(), prev_worlds=None):
    """One free particle (start of step x0) out of the projection primitives, then the mesh
    SDFs, each in turn, with friction: (new position, last contact's outward normal, moved)."""
    p = np.array(p, dtype=np.float64)
    normal, moved = np.zeros(3), False
    for ci, c in enumerate(colliders):
        world, kind, radii, h, mode, mu, _ = collider_params(c, head)
        if mode != "projection":
            continue
        pw = world if prev_worlds is None else prev_worlds[ci]
        R, t = world[:3, :3], world[:3, 3]
        pl = R.T @ (p - t)
        depth, n, sl = local_depth(pl, kind, radii, h)
        if depth <= 0:
            continue
        nw = R @ n
        p = p + R @ (sl - pl)
        if mu > 0:
            rel = apply(pw, sl) - x0
            tang = rel - (rel @ nw) * nw
            lt = np.linalg.norm(tang)
            p -= tang if lt <= mu * depth else tang * (mu * depth / lt)
        normal, moved = nw, True
    for sdf in sdfs:
        world, prev_world = np.asarray(sdf["world"], float), np.asarray(sdf.get("prev_world", sdf["world"]), float)
        margin, mu = sdf["margin"], sdf["friction"]
        inv, pinv = np.linalg.inv(world), np.linalg.inv(prev_world)
        x = apply(inv, p)
        dist = sdf_value(sdf, x)
        if not dist < margin:
            continue
        n = sdf_normal(sdf, x)
        depth = margin - dist
        x = x + depth * n
        disp = x - apply(pinv, x0)
        tang = disp - (disp @ n) * n
        slip = np.linalg.norm(tang)
        if slip > 0:
            x = x - min(mu * depth / slip, 1.0) * tang
        for _ in range(2):
            dist = sdf_value(sdf, x)
            if not dist < margin:
                break
            x = x + (margin - dist) * sdf_normal(sdf, x)
        p = apply(world, x)
        nw = world[:3, :3] @ n
        if np.linalg.norm(nw) > 0:
            normal = nw / np.linalg.norm(nw)
        moved = True
    return p, normal, moved


def sdf_value(sdf, x):
    """Trilinear sample of sdf["values"] (nodes at lo + ijk h), clamped, plus the distance to the box."""
    values, lo, h = sdf["values"], np.asarray(sdf["lo"], float), float(sdf["h"])
    res = np.array(values.shape)
    g = (x - lo) / h
    gc = np.clip(g, 0, res - 1)
    b = np.minimum(np.floor(gc).astype(int), res - 2)
    f = gc - b
    v = 0.0
    for c in range(8):
        o = np.array([c & 1, (c >> 1) & 1, (c >> 2) & 1])
        wgt = np.where(o == 1, f, 1 - f)
        v += wgt.prod() * float(values[tuple(b + o)])
    return v + np.linalg.norm(g - gc) * h


def sdf_normal(sdf, x):
    """The normalised central difference (step h / 2), taken at the nearest point whose stencil
    lies in the box (node coordinates clamped to [1/2, res - 2], as sdf_trilinear_diff)."""
    h, lo = float(sdf["h"]), np.asarray(sdf["lo"], float)
    x = lo + np.clip((np.asarray(x, float) - lo) / h, 0.5, np.array(sdf["values"].shape) - 2.0) * h
    e = 0.5 * h
    g = np.array([sdf_value(sdf, x + e * ax) - sdf_value(sdf, x - e * ax) for ax in np.eye(3)])
    n = np.linalg.norm(g)
    return g / n if n > 1e-12 else np.zeros(3)


def velocity(x, prev, d, w, dt, s_damping, max_speed):
    v = (x - prev) / dt
    if s_damping > 0:
        v[:, :-1] -= s_damping * d[:, 1:] / dt * (w[:, :-1, None] > 0)
    sp = np.linalg.norm(v, axis=2, keepdims=True)
    return np.where(sp > max_speed, v * max_speed / np.maximum(sp, 1e-300), v)


def step(x, prev, v, rest, w, head, dt, settings, colliders=(), time=0.0, sdfs=()):
    """One full step (no hair-hair passes, guard inert on finite data); the collisions happen
    inside the length constraint's sweep (DFTL) or iterations (PBD)."""
    seg = np.linalg.norm(np.diff(rest, axis=1), axis=2)
    arc = np.concatenate([np.zeros((len(rest), 1)), np.cumsum(seg, axis=1)], axis=1)
    x, prev = integrate(x, prev, v, rest, w, head, dt, settings, colliders, time)
    if settings.local_shape_stiffness > 0 or settings.bending_stiffness > 0:
        x = shape(x, w, rest, head, settings.local_shape_stiffness, settings.bending_stiffness,
                  settings.shape_iterations)
    d = np.zeros_like(x)
    prims = [c for c in colliders if c.mode == "projection"]
    if settings.length_method == "dftl":
        x, d = dftl(x, w, seg, rest, head, prev, prims, sdfs)
        s_damp = settings.dftl_damping
    else:
        x = pbd(x, w, seg, settings.pbd_iterations, settings.long_range_attachment, arc, prev, prims, sdfs,
                head=head, alpha_tilde=settings.stretch_compliance / dt ** 2)
        s_damp = 0.0
    v = velocity(x, prev, d, w, dt, s_damp, settings.max_speed)
    return x, prev, v


# ---------------------------------------------------------------------- test scenes
def straight_strands(S=8, N=16, length=0.3, direction=(0.0, 0.0, 1.0), spacing=0.01, origin=(0.0, 1.0, 0.0)):
    """(S, N, 3): straight strands from roots on a line along x."""
    d = np.asarray(direction, dtype=np.float64)
    d /= np.linalg.norm(d)
    t = np.linspace(0.0, length, N)
    roots = np.asarray(origin) + np.outer(np.arange(S) * spacing, [1.0, 0.0, 0.0])
    return roots[:, None, :] + t[None, :, None] * d


def helix_strands(S=4, N=32, radius=0.02, pitch=0.03, turns=3.0, spacing=0.1, origin=(0.0, 1.0, 0.0)):
    """(S, N, 3): curls hanging down (helix about -y), roots on a line along x."""
    a = np.linspace(0.0, 2 * np.pi * turns, N)
    pts = np.stack([radius * (np.cos(a) - 1.0), -pitch * a / (2 * np.pi), radius * np.sin(a)], axis=1)
    roots = np.asarray(origin) + np.outer(np.arange(S) * spacing, [1.0, 0.0, 0.0])
    return roots[:, None, :] + pts[None]


def curl_radius(p):
    """Mean circumradius of consecutive point triples of (S, N, 3) strands."""
    a, b, c = p[:, :-2], p[:, 1:-1], p[:, 2:]
    ab = np.linalg.norm(b - a, axis=2)
    bc = np.linalg.norm(c - b, axis=2)
    ca = np.linalg.norm(a - c, axis=2)
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=2)
    return float(np.mean(ab * bc * ca / np.maximum(2 * area2, 1e-30)))
