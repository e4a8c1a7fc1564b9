"""Chen's FLIP volume method on the CPU: NumPy/SciPy, float64, the same steps as ``FlipVolume``.

    new_v, info = flip_numpy(positions, velocities, dt, resolution=32)
    # positions, velocities: (N, 4) (xyz, w = inverse mass) or (N, 3) with inverse_masses=...

This is the CPU side of the CPU-vs-GPU comparison (Chen 2011, Table 2) and the twin that the
GPU kernels are tested against. Steps: trilinear particle -> MAC-face transfer (mass
weighted), cell classification (fluid / solid from an optional SDF / air), divergence with
an optional density source, Jacobi-preconditioned conjugate gradients on the 7-point
Laplacian (scipy.sparse matrix), pressure gradient, FLIP/PIC grid -> particle. See
``mane.sim.flip`` for the equations. Chen's CPU solver used a Modified Incomplete Cholesky
preconditioner: ``preconditioner="mic"`` gives MIC(0) (Bridson's formulation, tau = 0.97,
sigma = 0.25), its factorisation and triangular solves vectorised over the wavefronts
i + j + k = const; Jacobi is the default, as on the GPU.
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import UsageError
from .bounds import padded_box, particle_masses

AIR, FLUID, SOLID = 0, 1, 2


def grid_geometry(lo, hi, resolution: int) -> tuple[np.ndarray, float]:
    """Origin and cell size of the FLIP grid over the box [lo, hi] (float32, as on the GPU)."""
    lo = np.asarray(lo, np.float32)
    hi = np.asarray(hi, np.float32)
    h = np.float32(max(float((hi - lo).max()), 1e-30) / (resolution - 2))
    origin = np.float32(0.5) * (lo + hi) - np.float32(0.5 * resolution) * h
    return origin.astype(np.float64), float(h)


def _stencil(g, dims):
    dims = np.asarray(dims)
    g = np.clip(g, 0.0, dims - 1)
    base = np.minimum(np.floor(g).astype(np.int64), dims - 2)
    return base, g - base


_CORNERS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])


def _face_dims(R, a):
    d = [R, R, R]
    d[a] += 1
    return d


def _splat(g, values, dims):
    """Trilinear splat of values (n,) onto a node array of shape dims, g in node coordinates."""
    base, frac = _stencil(g, dims)
    size = int(np.prod(dims))
    out = np.zeros(size)
    for c in _CORNERS:
        w = np.prod(np.where(c == 1, frac, 1.0 - frac), axis=1)
        n = base + c
        flat = (n[:, 0] * dims[1] + n[:, 1]) * dims[2] + n[:, 2]
        out += np.bincount(flat, weights=w * values, minlength=size)
    return out.reshape(dims)


def _interp(g, field):
    base, frac = _stencil(g, field.shape)
    out = np.zeros(len(g))
    for c in _CORNERS:
        w = np.prod(np.where(c == 1, frac, 1.0 - frac), axis=1)
        n = base + c
        out += w * field[n[:, 0], n[:, 1], n[:, 2]]
    return out


def _face_sides(a: int, R: int) -> tuple[tuple, tuple]:
    """Index tuples into a grid of R^3 cells padded by one: the cells below and above each of the
    (R + 1) axis-``a`` faces (shaped like that axis' face grid)."""
    sl_lo = [slice(1, R + 1)] * 3
    sl_hi = [slice(1, R + 1)] * 3
    sl_lo[a] = slice(0, R + 1)
    sl_hi[a] = slice(1, R + 2)
    return tuple(sl_lo), tuple(sl_hi)


def _shift(g, a):
    s = np.full(3, 0.5)
    s[a] = 0.0
    return g - s


def _laplacian(markers):
    """The 7-point matrix over fluid cells (diag = non-solid neighbours, -1 per fluid neighbour)."""
    import scipy.sparse as sp

    R = markers.shape[0]
    fluid = markers == FLUID
    index = -np.ones(markers.shape, np.int64)
    nf = int(fluid.sum())
    index[fluid] = np.arange(nf)
    padded = np.pad(markers, 1, constant_values=AIR)
    diag = np.zeros(markers.shape)
    rows, cols = [], []
    for a in range(3):
        for s in (-1, 1):
            sl = [slice(1, R + 1)] * 3
            sl[a] = slice(1 + s, R + 1 + s)
            nbr = padded[tuple(sl)]
            diag += nbr != SOLID
            pair = fluid & (nbr == FLUID)
            src = index[pair]
            sh = np.roll(index, -s, axis=a)   # neighbour's index (valid where pair holds: no wrap)
            rows.append(src)
            cols.append(sh[pair])
    rows = np.concatenate(rows)
    cols = np.concatenate(cols)
    d = diag[fluid]
    A = sp.csr_matrix((np.concatenate([d, -np.ones(len(rows))]),
                       (np.concatenate([np.arange(nf), rows]), np.concatenate([np.arange(nf), cols]))),
                      shape=(nf, nf))
    return A, d, index, diag


class MIC0:
    """Modified incomplete Cholesky, MIC(0), of the fluid-cell Laplacian (Bridson 2008, ch. 4).

    Cells are processed by wavefronts s = i + j + k (each depends only on the previous one),
    so every sweep is ~3R vectorised NumPy steps. ``apply(r)`` solves L L^T z = r for r over
    the fluid cells in C order (the order of ``markers == FLUID``).
    """

    def __init__(self, markers, tau: float = 0.97, sigma: float = 0.25):
        R = markers.shape[0]
        P = R + 2
        self.size = P ** 3
        self.strides = (P * P, P, 1)
        fluid = np.pad(markers == FLUID, 1)
        padded_markers = np.pad(markers, 1, constant_values=AIR)
        flat_fluid = fluid.reshape(-1)
        cells = np.nonzero(flat_fluid)[0]                          # padded flat index, C order
        self.cells = cells
        diag = np.zeros(self.size)
        for a, st in enumerate(self.strides):
            for sgn in (-1, 1):
                diag[cells] += padded_markers.reshape(-1)[cells + sgn * st] != SOLID
        # A_plus[a][c] = -1 when c and its +a neighbour are both fluid
        self.plus = []
        for st in self.strides:
            ap = np.zeros(self.size)
            both = flat_fluid[cells] & flat_fluid[cells + st]
            ap[cells[both]] = -1.0
            self.plus.append(ap)
        ijk = np.stack(np.unravel_index(cells, fluid.shape), axis=1) - 1
        wave = ijk.sum(axis=1)
        order = np.argsort(wave, kind="stable")
        bounds = np.searchsorted(wave[order], np.arange(wave.max() + 2 if len(wave) else 1))
        self.waves = [cells[order[bounds[w]:bounds[w + 1]]] for w in range(len(bounds) - 1)]
        precon = np.zeros(self.size)
        Ai, Aj, Ak = self.plus
        di, dj, dk = self.strides
        for c in self.waves:
            if not len(c):
                continue
            pi, pj, pk = precon[c - di], precon[c - dj], precon[c - dk]
            e = (diag[c] - (Ai[c - di] * pi) ** 2 - (Aj[c - dj] * pj) ** 2 - (Ak[c - dk] * pk) ** 2
                 - tau * (Ai[c - di] * (Aj[c - di] + Ak[c - di]) * pi ** 2
                          + Aj[c - dj] * (Ai[c - dj] + Ak[c - dj]) * pj ** 2
                          + Ak[c - dk] * (Ai[c - dk] + Aj[c - dk]) * pk ** 2))
            e = np.where(e < sigma * diag[c], diag[c], e)
            precon[c] = np.where(e > 0, 1.0 / np.sqrt(np.where(e > 0, e, 1.0)), 0.0)
        self.precon = precon

    def apply(self, r):
        Ai, Aj, Ak = self.plus
        di, dj, dk = self.strides
        pc = self.precon
        q = np.zeros(self.size)
        full = np.zeros(self.size)
        full[self.cells] = r
        for c in self.waves:
            t = (full[c] - Ai[c - di] * pc[c - di] * q[c - di] - Aj[c - dj] * pc[c - dj] * q[c - dj]
                 - Ak[c - dk] * pc[c - dk] * q[c - dk])
            q[c] = t * pc[c]
        z = np.zeros(self.size)
        for c in reversed(self.waves):
            t = q[c] - pc[c] * (Ai[c] * z[c + di] + Aj[c] * z[c + dj] + Ak[c] * z[c + dk])
            z[c] = t * pc[c]
        return z[self.cells]


def pcg(A, b, diag, tolerance=1e-5, max_iterations=200, preconditioner="jacobi", markers=None):
    """Preconditioned CG as on the GPU: stop when max|r| <= tolerance * max|b|."""
    x = np.zeros_like(b)
    bmax = float(np.abs(b).max()) if len(b) else 0.0
    if bmax == 0.0:
        return x, {"iterations": 0, "residual": 0.0, "residual_abs": 0.0, "rhs_max": 0.0}
    safe = np.where(diag > 0, diag, 1.0)
    if preconditioner == "jacobi":
        apply_m = lambda r: np.where(diag > 0, r / safe, 0.0)  # noqa: E731
    elif preconditioner == "mic":
        if markers is None:
            raise UsageError("the MIC preconditioner needs the cell markers")
        apply_m = MIC0(markers).apply
    else:
        raise UsageError(f"preconditioner must be 'jacobi' or 'mic', got {preconditioner!r}")
    r = b.copy()
    z = apply_m(r)
    d = z.copy()
    sigma = float(r @ z)
    rmax = bmax
    threshold = tolerance * bmax
    it = 0
    if rmax > threshold:
        for it in range(1, int(max_iterations) + 1):
            q = A @ d
            dq = float(d @ q)
            alpha = sigma / dq if dq != 0 else 0.0
            x += alpha * d
            r -= alpha * q
            rmax = float(np.abs(r).max())
            if rmax <= threshold:
                break
            z = apply_m(r)
            sigma_new = float(r @ z)
            beta = sigma_new / sigma if sigma > 0 else 0.0
            sigma = sigma_new
            d = z + beta * d
    return x, {"iterations": it, "residual": rmax / bmax, "residual_abs": rmax, "rhs_max": bmax}


def flip_numpy(positions, velocities, dt: float, resolution: int = 32, flip_ratio: float = 0.95,
               density_target: float | None = None, tolerance: float = 1e-5, max_iterations: int = 200,
               bounds=None, *, inverse_masses=None, mass_unit: float = 1.0, pinned_mass: float = 1.0,
               density_stiffness: float = 1.0, solid=None, solid_transform=None, solid_level: float = 0.0,
               preconditioner: str = "jacobi", bounds_relative_margin: float = 0.05,
               return_state: bool = False, rest_density: float | None = None):
    """One FLIP volume step on the CPU. Returns (new velocities (N, 3) float64, info).

    positions: (N, 4) with w = inverse mass (0 = pinned) or (N, 3) plus ``inverse_masses``.
    bounds: (lo, hi) of the grid box, or None for the padded particle box (as GridBounds with
    ``relative_margin=bounds_relative_margin``, not cubic). solid: a MeshSDF (or any object
    with ``sample(points)``) in its local frame, ``solid_transform`` its local-to-world 4x4.
    info: iterations, residual (max|r| / max|b|), residual_abs, rhs_max, seconds; with
    ``return_state`` also markers, density, pressure, u, u_star, origin, h.
    """
    t0 = time.perf_counter()
    pos = np.asarray(positions, np.float64)
    vel = np.asarray(velocities, np.float64)[:, :3]
    if inverse_masses is None:
        if pos.shape[1] < 4:
            raise UsageError("flip_numpy: give (N, 4) positions with w = inverse mass, or inverse_masses=")
        inverse_masses = pos[:, 3]
    x = pos[:, :3]
    R = int(resolution)
    if bounds is None:
        lo, hi = padded_box(x, relative_margin=bounds_relative_margin, cubic=False)
    else:
        lo, hi = bounds
    origin, h = grid_geometry(lo, hi, R)
    finite = np.all(np.isfinite(x), axis=1)
    m = particle_masses(inverse_masses, pinned_mass) / mass_unit
    use = finite & (m > 0)
    g = (np.where(finite[:, None], x, 0.0) - origin) / h

    # 1. particle -> grid
    u_star, face_mass = [], []
    for a in range(3):
        dims = _face_dims(R, a)
        mass = _splat(_shift(g[use], a), m[use], dims)
        mom = _splat(_shift(g[use], a), m[use] * vel[use, a], dims)
        u_star.append(np.divide(mom, mass, out=np.zeros_like(mom), where=mass > 0))
        face_mass.append(mass)
    cell = np.clip(np.floor(g[use]).astype(np.int64), 0, R - 1)
    count = np.zeros((R, R, R), np.int64)
    np.add.at(count, (cell[:, 0], cell[:, 1], cell[:, 2]), 1)
    density = _splat(g[use] - 0.5, m[use], [R, R, R])

    # 2. classify
    markers = np.where(count > 0, FLUID, AIR)
    if solid is not None:
        idx = np.indices((R, R, R)).reshape(3, -1).T
        centres = origin + (idx + 0.5) * h
        if solid_transform is not None:
            inv = np.linalg.inv(np.asarray(solid_transform, np.float64))
            centres = centres @ inv[:3, :3].T + inv[:3, 3]
        sdf = np.asarray(solid.sample(centres)).reshape(R, R, R)
        markers = np.where(sdf < solid_level, SOLID, markers)
    padded = np.pad(markers, 1, constant_values=AIR)
    u = []
    for a in range(3):
        sl_lo, sl_hi = _face_sides(a, R)
        lower, upper = padded[sl_lo], padded[sl_hi]
        u.append(np.where((lower == SOLID) | (upper == SOLID), 0.0, u_star[a]))

    # 3. divergence and source
    fluid = markers == FLUID
    D = sum(np.diff(u[a], axis=a) for a in range(3))
    A, diag_f, index, diag = _laplacian(markers)
    S = np.zeros((R, R, R))
    if rest_density is not None:   # mass units per m^3: the target per cell of this grid
        density_target = rest_density * h ** 3
    if density_target is not None:
        S = h * (density_stiffness / dt) * np.maximum(density - density_target, 0.0) / density_target
    b = np.where(diag > 0, S - D, 0.0)[fluid]

    # 4. pressure
    p_f, info = pcg(A, b, diag_f, tolerance, max_iterations, preconditioner, markers)
    pressure = np.zeros((R, R, R))
    pressure[fluid] = p_f

    # 5. gradient
    pp = np.pad(pressure, 1)
    for a in range(3):
        sl_lo, sl_hi = _face_sides(a, R)
        lower, upper = padded[sl_lo], padded[sl_hi]
        ok = (lower != SOLID) & (upper != SOLID) & ((lower == FLUID) | (upper == FLUID))
        u[a] = np.where(ok, u[a] - (pp[sl_hi] - pp[sl_lo]), u[a])

    # 6. grid -> particle
    new = vel.copy()
    move = finite & (np.asarray(inverse_masses) > 0)
    for a in range(3):
        ga = _shift(g[move], a)
        pic = _interp(ga, u[a])
        delta = _interp(ga, u[a] - u_star[a])
        new[move, a] = flip_ratio * (vel[move, a] + delta) + (1.0 - flip_ratio) * pic
    info["seconds"] = time.perf_counter() - t0
    if return_state:
        info.update(markers=markers, density=density, pressure=pressure, u=u, u_star=u_star,
                    face_mass=face_mass, origin=origin, h=h, divergence=D, source=S)
    return new, info
