"""Chen's FLIP volume method for hair (Chen 2011 §4.2, after Bridson and Petrovic), on the GPU.

    flip = FlipVolume(ctx, resolution=32)
    info = flip.apply(positions, velocities, num_particles, dt, flip_ratio=0.95)
    info  # {"iterations": 23, "residual": 8.1e-06}

One ``apply`` (all on the GPU; the CPU only dispatches and, every ``check_every`` PCG
iterations, reads two doubles to test convergence):

1. **particle -> grid**: each velocity component goes to the 8 faces of its staggered MAC
   stencil with trilinear weights; faces keep sum(m w v) and sum(m w) in 64-bit fixed point
   (two 32-bit atomics with a carry; each term rounded to 2^-32 of a mass unit) and
   u* = sum(m w v) / sum(m w). Cells count their particles and collect trilinear mass at their
   centres (the density, in mass units per cell).
2. **classify**: SOLID where an optional :class:`~mane.sim.sdf.MeshSDF` is below
   ``solid_level`` at the cell centre, FLUID where a particle lies, AIR elsewhere. Faces that
   touch a solid take the solid's velocity (0).
3. **divergence**: D = sum of face differences on fluid cells; with ``density_target`` a
   volume-preservation source S = h k max(rho - rho0, 0) / (rho0 dt) is added (cells denser
   than the target push outwards; k = ``density_stiffness``).
4. **pressure**: A p = S - D with A the 7-point Laplacian over fluid cells (diagonal = number
   of non-solid neighbours, air p = 0, solid Neumann), by conjugate gradients with a Jacobi
   preconditioner. Dot products are two-stage parallel reductions (double precision);
   alpha and beta stay on the GPU. Stops when max|r| <= tolerance * max|b| or after
   ``max_iterations``. rho/dt is dropped as in Chen (it cancels).
5. **gradient**: u -= p(upper) - p(lower) on faces next to a fluid cell and no solid.
6. **grid -> particle** (Chen eq. 5): v = a (v_p + Lerp(u - u*)) + (1 - a) Lerp(u), a the
   FLIP ratio (1 = FLIP, 0 = PIC). Pinned particles (w = 0) keep their velocity.

The grid: ``resolution``^3 cubic cells, h = (largest side of the GridBounds box) / (R - 2),
centred on the box, so the box lies in cells 1..R-2. Cells beyond the grid are air (a free
surface); there are no walls. :func:`mane.sim.flip_cpu.flip_numpy` is the same method in
NumPy/SciPy (float64) for checks and the CPU-vs-GPU benchmark (Chen Table 2).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UsageError
from .bounds import (BOUNDS_BINDING, GridBounds, check_particle_buffers, groups, is_state,
                     set_uniforms, storage_barrier)
from .bindings import (B_ACCUMULATOR, B_CELLS, B_FACES, B_PARTIALS, B_PARTICLE_VELOCITIES, B_POSITIONS,
                       B_SCALARS)

HERE = Path(__file__).resolve().parent
AIR, FLUID, SOLID = 0, 1, 2
CELL_FLOATS = 8  # p, r, z, d, q, density, marker, diag
REST_PERCENTILE = 90.0
"""The rest density is this percentile of the occupied cells' densities at rest: the source
pushes apart only cells denser than that (it is one-sided). Measured (600 radial strands on a
head, shaken 1 s, occupied 2 cm cells against rest): the mean puffs the groom out by up to 25%,
the 98th percentile lets it collapse by 31%, the 90th keeps it within 8.4%; with no target
(the divergence-free projection alone) it collapses to 18-21%."""


class FlipVolume:
    """FLIP pressure projection on a ``resolution``^3 MAC grid (8..128; Chen used 16-64).

    mass_unit: kg per unit of grid mass (fixed-point resolution 2^-32, range 2^31 of it).
    pinned_mass: kg a pinned particle (w = 0) brings to the grid (0: pinned particles are
    ignored). density_stiffness: k of the volume-preservation source. check_every: PCG
    iterations between convergence readbacks (1 reports the exact count; larger values
    save GPU stalls and may run up to check_every - 1 extra iterations).
    """

    def __init__(self, ctx, resolution: int = 32, *, mass_unit: float = 1.0, pinned_mass: float = 1.0,
                 density_stiffness: float = 1.0, check_every: int = 1,
                 bounds_margin: float = 0.0, bounds_relative_margin: float = 0.05):
        from ..gpu.glsl import compute_shader

        resolution = int(resolution)
        if not 4 <= resolution <= 256:
            raise UsageError(f"FlipVolume resolution must be in 4..256 (16..64 is usual), got {resolution}")
        if mass_unit <= 0 or pinned_mass < 0 or density_stiffness < 0 or check_every < 1:
            raise UsageError("FlipVolume: mass_unit > 0, pinned_mass >= 0, density_stiffness >= 0, check_every >= 1")
        self.ctx = ctx
        self.resolution = R = resolution
        self.mass_unit = float(mass_unit)
        self.pinned_mass = float(pinned_mass)
        self.density_stiffness = float(density_stiffness)
        self.check_every = int(check_every)
        self.num_cells = R ** 3
        self.faces_per_axis = (R + 1) * R * R
        self.num_faces = 3 * self.faces_per_axis
        self.num_partials = groups(self.num_cells, 256)
        self._own_bounds = GridBounds(ctx, margin=bounds_margin, relative_margin=bounds_relative_margin,
                                      cubic=False)
        self.bounds: GridBounds = self._own_bounds

        from ..gpu.buffers import as_device, check_allocation

        check_allocation(ctx, (self.num_faces + self.num_cells) * 16 + self.num_faces * 8
                         + self.num_cells * CELL_FLOATS * 4 + self.num_partials * 16 + 64,
                         f"the FLIP volume's {resolution}^3 grid", ssbo=False,
                         reduce="Use a smaller flip grid resolution")
        self.accumulator = as_device(ctx.buffer(reserve=(self.num_faces + self.num_cells) * 16))
        self.accumulator.clear()
        self.faces = as_device(ctx.buffer(reserve=self.num_faces * 8))               # vec2(u, u*)
        self.cells = as_device(ctx.buffer(reserve=self.num_cells * CELL_FLOATS * 4))
        self.partials = as_device(ctx.buffer(reserve=self.num_partials * 16))        # dvec2
        self.scalars = as_device(ctx.buffer(reserve=64))                              # 8 doubles

        d = {"GRID_RES": R, "BOUNDS_BINDING": BOUNDS_BINDING}
        k = lambda name, **extra: compute_shader(ctx, HERE / name, dict(d, **extra))  # noqa: E731
        self._p2g = k("flip_p2g.comp")
        self._classify = {False: k("flip_classify.comp", HAS_SDF=0)}
        self._classify_sdf = lambda: k("flip_classify.comp", HAS_SDF=1)
        self._faces = k("flip_faces.comp")
        self._divergence = k("flip_divergence.comp")
        self._matvec = k("pcg_apply.comp")
        self._update = k("pcg_update.comp")
        self._direction = k("pcg_direction.comp")
        self._reduce = {s: k("pcg_reduce.comp", **{f"STAGE_{s}": 1}) for s in ("INIT", "ALPHA", "BETA")}
        self._gradient = k("flip_gradient.comp")
        self._g2p = k("flip_g2p.comp")

    # ------------------------------------------------------------------ steps
    def _bind(self, positions=None, velocities=None):
        if positions is not None:
            positions.bind_to_storage_buffer(B_POSITIONS)
        if velocities is not None:
            velocities.bind_to_storage_buffer(B_PARTICLE_VELOCITIES)
        self.accumulator.bind_to_storage_buffer(B_ACCUMULATOR)
        self.faces.bind_to_storage_buffer(B_FACES)
        self.cells.bind_to_storage_buffer(B_CELLS)
        self.partials.bind_to_storage_buffer(B_PARTIALS)
        self.scalars.bind_to_storage_buffer(B_SCALARS)
        self.bounds.bind()

    def _run(self, shader, count: int, local: int) -> None:
        shader.run(groups(count, local))
        storage_barrier(self.ctx)

    def _reduce_stage(self, stage: str) -> None:
        set_uniforms(self._reduce[stage], num_partials=self.num_partials)
        self._run(self._reduce[stage], 256, 256)

    def _read_scalars(self) -> np.ndarray:
        return np.frombuffer(self.scalars.read(), dtype=np.float64)

    def transfer_to_grid(self, positions, velocities, num_particles: int, *, solid=None,
                         solid_transform=None, solid_level: float = 0.0) -> None:
        """Steps 1-2: P2G, classification and face velocities (u and u*)."""
        n = num_particles
        self._bind(positions, velocities)
        if n:
            set_uniforms(self._p2g, num_particles=n, pinned_mass=self.pinned_mass / self.mass_unit,
                         inv_mass_unit=1.0 / self.mass_unit)
            self._run(self._p2g, n, 128)
        if solid is None:
            classify = self._classify[False]
        else:
            classify = self._classify_sdf()
            m = np.eye(4) if solid_transform is None else np.asarray(solid_transform, np.float64)
            world_to_local = np.linalg.inv(m)
            solid.bind_for_sampling(classify, unit=0)
            set_uniforms(classify, world_to_sdf=tuple(world_to_local.T.astype(np.float32).ravel()),
                         solid_level=float(solid_level))
        self._run(classify, self.num_cells, 256)
        self._run(self._faces, self.num_faces, 256)

    def solve_pressure(self, dt: float, density_target=None, tolerance: float = 1e-5,
                       max_iterations: int = 200, rest_density=None) -> dict:
        """Steps 3-5: divergence, Jacobi-PCG pressure solve and gradient subtraction."""
        self._bind()
        target = 0.0 if density_target is None else float(density_target)
        set_uniforms(self._divergence, density_target=target,
                     rest_density=0.0 if rest_density is None else float(rest_density),
                     density_gain=self.density_stiffness / float(dt) if dt > 0 else 0.0)
        self._run(self._divergence, self.num_cells, 256)
        self._reduce_stage("INIT")
        s = self._read_scalars()
        bmax = float(s[4])
        rmax = float(s[3])
        iterations = 0
        threshold = float(tolerance) * bmax
        if bmax > 0.0 and rmax > threshold:
            for it in range(1, int(max_iterations) + 1):
                self._run(self._matvec, self.num_cells, 256)
                self._reduce_stage("ALPHA")
                self._run(self._update, self.num_cells, 256)
                self._reduce_stage("BETA")
                iterations = it
                if it % self.check_every == 0 or it == max_iterations:
                    rmax = float(self._read_scalars()[3])
                    if rmax <= threshold:
                        break
                self._run(self._direction, self.num_cells, 256)
            else:
                rmax = float(self._read_scalars()[3])
        self._run(self._gradient, self.num_faces, 256)
        return {"iterations": iterations, "residual": rmax / bmax if bmax > 0 else 0.0,
                "residual_abs": rmax, "rhs_max": bmax}

    def transfer_to_particles(self, positions, velocities, num_particles: int, flip_ratio: float) -> None:
        """Step 6: v = a (v + Lerp(u - u*)) + (1 - a) Lerp(u); pinned particles unchanged."""
        if not num_particles:
            return
        self._bind(positions, velocities)
        set_uniforms(self._g2p, num_particles=int(num_particles), flip_ratio=float(flip_ratio))
        self._run(self._g2p, num_particles, 128)

    def apply(self, positions, *args, **kwargs) -> dict:
        """``apply(positions, velocities, num_particles, dt, flip_ratio=0.95, ...)`` or
        ``apply(state, dt, flip_ratio=0.95, ...)`` with a SimState; see ``_apply``."""
        if is_state(positions):
            st = positions
            return self._apply(st.positions, st.velocities, st.num_particles, *args, **kwargs)
        return self._apply(positions, *args, **kwargs)

    def _apply(self, positions, velocities, num_particles: int, dt: float, flip_ratio: float = 0.95,
              density_target: float | None = None, tolerance: float = 1e-5, max_iterations: int = 200,
              bounds: GridBounds | None = None, *, solid=None, solid_transform=None,
              solid_level: float = 0.0, rest_density: float | None = None) -> dict:
        """Make the particles' velocity field divergence-free (in place on ``velocities``).

        dt: seconds (only the density source uses it). flip_ratio: 0 = PIC .. 1 = FLIP.
        density_target: mass units per cell (e.g. particles per cell at unit mass) or None.
        rest_density: mass units per m^3 (``measure_rest_density``), the target then being
        rest_density h^3 for this step's cell size h; overrides density_target.
        bounds: a shared GridBounds (already updated this step) or None for the own one.
        solid: a MeshSDF whose cells below ``solid_level`` (metres) are solid; solid_transform:
        its 4x4 local-to-world matrix. Returns {"iterations", "residual" (max|r|/max|b|),
        "residual_abs", "rhs_max"}.
        """
        n = check_particle_buffers(num_particles, positions, velocities)
        if not 0.0 <= flip_ratio <= 1.0:
            raise UsageError(f"flip_ratio must be in [0, 1], got {flip_ratio}")
        if rest_density is not None and not rest_density > 0:
            raise UsageError(f"rest_density must be > 0 (mass units per m^3) or None, got {rest_density}")
        if density_target is not None and density_target <= 0:
            raise UsageError(f"density_target must be > 0 (mass units per cell) or None, got {density_target}")
        if tolerance <= 0 or max_iterations < 0:
            raise UsageError("tolerance must be > 0 and max_iterations >= 0")
        if bounds is None:
            bounds = self._own_bounds
            bounds.update(positions, n)
        self.bounds = bounds
        self.transfer_to_grid(positions, velocities, n, solid=solid, solid_transform=solid_transform,
                              solid_level=solid_level)
        info = self.solve_pressure(dt, density_target, tolerance, max_iterations, rest_density)
        self.transfer_to_particles(positions, velocities, n, flip_ratio)
        return info

    def measure_rest_density(self, positions, velocities, num_particles: int) -> float:
        """The target of Chen's volume method taken from a rest state: the ``REST_PERCENTILE``
        percentile of the fluid cells' trilinear mass per cell volume, mass units per m^3, with
        the grid fitted to these positions ((N, 4) buffer, w inverse mass). Leaves the grid as
        a transfer does."""
        n = check_particle_buffers(num_particles, positions, velocities)
        self.bounds = self._own_bounds
        self.bounds.update(positions, n)
        self.transfer_to_grid(positions, velocities, n)
        g = self.read_state()
        fluid = g["markers"] == FLUID
        if not fluid.any():
            raise UsageError("no particle on the grid: no rest density")
        return float(np.percentile(g["density"][fluid], REST_PERCENTILE)) / float(g["h"]) ** 3

    # ------------------------------------------------------------------ readback (tests, debugging)
    def grid_geometry(self) -> tuple[np.ndarray, float]:
        """(origin (3,), h) of the grid as the shaders compute it from the bounds."""
        lo, hi = self.bounds.read()
        h = np.float32(max(float((hi - lo).max()), 1e-30) / (self.resolution - 2))
        origin = np.float32(0.5) * (lo + hi) - np.float32(0.5 * self.resolution) * h
        return origin.astype(np.float32), float(h)

    def read_state(self) -> dict:
        """Markers, density, pressure (R,R,R) and face arrays u, u_star: 3 arrays each, [i, j, k]."""
        R = self.resolution
        cells = np.frombuffer(self.cells.read(), dtype=np.float32).reshape(R, R, R, CELL_FLOATS)
        cells = cells.transpose(2, 1, 0, 3)
        markers = cells[..., 6].copy().view(np.uint32).astype(np.int32)
        faces = np.frombuffer(self.faces.read(), dtype=np.float32).reshape(3, -1, 2)
        u, u_star = [], []
        for a in range(3):
            dims = [R, R, R]
            dims[a] += 1
            f = faces[a].reshape(dims[2], dims[1], dims[0], 2).transpose(2, 1, 0, 3)
            u.append(f[..., 0].copy())
            u_star.append(f[..., 1].copy())
        origin, h = self.grid_geometry()
        return {"markers": markers, "density": cells[..., 5].copy(), "pressure": cells[..., 0].copy(),
                "u": u, "u_star": u_star, "origin": origin, "h": h}

    def release(self) -> None:
        for b in (self.accumulator, self.faces, self.cells, self.partials, self.scalars):
            b.release()
        self._own_bounds.release()
