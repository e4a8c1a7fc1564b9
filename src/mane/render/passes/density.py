"""Density ray-marched shadows (Woodhouse 2012's ``optimised_gpu``): light 0's transmittance
through a 3D texture of the hair's extinction, marched from each shaded point toward the light.

The texture holds sigma (1/m) on a node grid spanning a GridBounds box (the simulator's layout:
node i at lo + i (hi - lo) / (R - 1), read trilinearly): the strands' cross-section per volume
times their opacity, sum(width * length * strand_opacity) / cell volume, so that one strand
crossed at right angles gives an optical depth of about strand_opacity (and
T = exp(-shadow_density * integral sigma ds), the convention of the opacity maps). Built each
frame on the GPU with no readback, from one of:

- ``"strands"``: the rendered strands (tessellated, clumped, strays) drawn once more with a
  geometry shader (``density_splat.geom``) that samples every segment at half-cell steps and
  adds w ds alpha with trilinear (tent) weights to the 8 nodes around each sample, atomically
  in 2^-16 fixed point; the box is a GridBounds over the guide points padded by the clump
  radius (not cubic: thin grooms keep their resolution). Works for static grooms and
  simulations alike.
- ``"simulator"``: the simulator's hair-hair friction grid (``GridFriction.grid``, mass per
  node of the guide particles, and its GridBounds box), read in place: sigma = mass x
  (strands per guide x guide segment length x mean width x alpha per unit of particle mass)
  / cell volume. Guides only: blurrier (clump offsets are not in it) but free while simulating.
"""
from __future__ import annotations

import numpy as np

from ...errors import UsageError
from ...gpu.glsl import compute_shader
from ..bindings import B_DENSITY_ACC, B_DENSITY_BOX, B_SIM_GRID, IMG_DENSITY
from .base import HERE, PASS_SHADOW_DEPTH, Frame, draw_hair, hair_program, set_uniform
from .light_depth import LightDepthPass

FIXED_SCALE = 65536.0


def simulator_grid(renderer):
    """The simulator's GridFriction when the strands come from a simulator that has built one."""
    st = renderer.strands
    sim = getattr(st, "source", None) if st is not None else None
    grid = getattr(sim, "friction_grid", None) if sim is not None and hasattr(sim, "state") else None
    return grid if grid is not None and hasattr(grid, "grid") and hasattr(grid, "bounds") else None


class DensityPass(LightDepthPass):
    """No light-depth map: ``texture`` is a 3D texture of the strands' (or the simulator grid's)
    density, and ``read``, ``release`` are the pass's own."""

    name = "density"
    method = "density"
    reads = ("strands",)
    writes = ("density",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.texture = None
        self.bounds = None
        self.source = None           # "strands" or "simulator", after a run
        self._sim_texture = None
        self._sim_scale = None

    def _source(self) -> str:
        want = self.renderer.settings.density_source
        grid = simulator_grid(self.renderer)
        if want == "simulator" and grid is None:
            raise UsageError("density_source='simulator' needs strands from a Simulator with hair-hair "
                             "friction on (its grid); use 'strands' or 'auto'")
        if want == "auto":
            return "simulator" if grid is not None else "strands"
        return want

    def run(self, frame: Frame) -> None:
        self.source = self._source()
        if self.source == "simulator":
            tex, box = self._from_simulator()
        else:
            tex, box = self._from_strands(frame)
        frame.targets["density"] = (tex, box)

    # ------------------------------------------------------------------ rendered strands
    def _from_strands(self, frame: Frame):
        from ...gpu.bounds import GridBounds

        ctx, r = self.ctx, self.renderer
        s = r.settings
        R = int(s.density_resolution)
        if self.texture is None or self.texture.size[0] != R:
            self._release_own()
            from ...gpu.buffers import as_device, check_texture

            check_texture(ctx, (R, R, R), 1, 4, f"the {R}^3 density grid", extra_bytes=R ** 3 * 4,
                          reduce="Use a smaller density_resolution")
            self.texture = ctx.texture3d((R, R, R), 1, dtype="f4")
            self.texture.filter = (ctx.LINEAR, ctx.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
            self.accumulator = as_device(ctx.buffer(reserve=R ** 3 * 4))
            self.accumulator.clear()
            pad = float(s.clump_radius) * (1.0 + float(s.stray_amount)) + float(s.width)
            self.bounds = GridBounds(ctx, margin=pad, relative_margin=0.02, cubic=False)
            self._target = ctx.texture((1, 1), 1, dtype="f4")
            self._fbo = ctx.framebuffer([self._target])
        st = r.strands
        self.bounds.update(st.positions, st.num_points)
        # splat the rendered segments (the geometry shader emits nothing; llvmpipe skips the
        # geometry shader under GL_RASTERIZER_DISCARD, so a 1x1 target stays bound instead)
        prog = hair_program(r, PASS_SHADOW_DEPTH, geometry_file=HERE / "density_splat.geom",
                            fragment_file=HERE / "density_splat.frag",
                            extra_defines={"DENSITY_RES": R, "B_DENSITY_BOX": B_DENSITY_BOX,
                                           "B_DENSITY_ACC": B_DENSITY_ACC,
                                           "FIXED_SCALE": f"{FIXED_SCALE:.1f}"})
        set_uniform(prog, "u_strand_opacity", float(s.strand_opacity))
        self.bounds.buffer.bind_to_storage_buffer(B_DENSITY_BOX)
        self.accumulator.bind_to_storage_buffer(B_DENSITY_ACC)
        self._fbo.use()
        ctx.disable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        draw_hair(r, prog, frame.light_view)   # any view: nothing is rasterised
        ctx.memory_barrier()
        # fixed point -> float texture, and clear the accumulator for the next frame
        cs = compute_shader(ctx, HERE / "density_resolve.comp",
                            {"DENSITY_RES": R, "B_DENSITY_ACC": B_DENSITY_ACC,
                             "FIXED_SCALE": f"{FIXED_SCALE:.1f}", "FROM_GRID": 0})
        self.accumulator.bind_to_storage_buffer(B_DENSITY_ACC)
        self.texture.bind_to_image(IMG_DENSITY, read=False, write=True)
        cs.run((R ** 3 + 63) // 64)
        ctx.memory_barrier()
        ctx.enable(ctx.DEPTH_TEST)
        return self.texture, self.bounds.buffer

    # ------------------------------------------------------------------ the simulator's grid
    def _from_simulator(self):
        ctx, r = self.ctx, self.renderer
        grid = simulator_grid(r)
        R = int(grid.resolution)
        if self._sim_texture is None or self._sim_texture.size[0] != R:
            if self._sim_texture is not None:
                self._sim_texture.release()
            self._sim_texture = ctx.texture3d((R, R, R), 1, dtype="f4")
            self._sim_texture.filter = (ctx.LINEAR, ctx.LINEAR)
            self._sim_texture.repeat_x = self._sim_texture.repeat_y = self._sim_texture.repeat_z = False
            self._sim_scale = None
        if self._sim_scale is None:
            self._sim_scale = self.area_per_mass(grid)
        cs = compute_shader(ctx, HERE / "density_resolve.comp",
                            {"DENSITY_RES": R, "B_SIM_GRID": B_SIM_GRID,
                             "B_DENSITY_BOX": B_DENSITY_BOX, "FROM_GRID": 1})
        set_uniform(cs, "u_area_per_mass", float(self._sim_scale))
        grid.grid.bind_to_storage_buffer(B_SIM_GRID)
        grid.bounds.buffer.bind_to_storage_buffer(B_DENSITY_BOX)
        self._sim_texture.bind_to_image(IMG_DENSITY, read=False, write=True)
        cs.run((R ** 3 + 63) // 64)
        ctx.memory_barrier()
        return self._sim_texture, grid.bounds.buffer

    def area_per_mass(self, grid) -> float:
        """alpha-weighted strand area (m^2) that one unit of the friction grid's mass stands for."""
        s = self.renderer.settings
        st = self.renderer.strands
        sim = st.source
        inv = np.asarray(sim.state.inv_mass, np.float64).reshape(-1)
        mass = np.where(inv > 0, 1.0 / np.where(inv > 0, inv, 1.0), grid.pinned_mass) / grid.mass_unit
        p = st.read_positions().astype(np.float64)          # once: guide lengths
        seg = np.linalg.norm(np.diff(p, axis=1), axis=2)
        length_per_particle = float(seg.sum()) / max(p.shape[0] * p.shape[1], 1)
        mean_width = float(s.width) * 0.5 * (1.0 + float(s.width_tip))
        area = int(s.strands_per_guide) * length_per_particle * mean_width * float(s.strand_opacity)
        return area / max(float(mass.mean()), 1e-30)

    def read(self) -> np.ndarray:
        """(R, R, R) float32 sigma (1/m) indexed [x, y, z], and nothing else: see ``box``."""
        tex = self._sim_texture if self.source == "simulator" else self.texture
        R = tex.size[0]
        return np.frombuffer(tex.read(), np.float32).reshape(R, R, R).transpose(2, 1, 0).copy()

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        buf = simulator_grid(self.renderer).bounds.buffer if self.source == "simulator" else self.bounds.buffer
        b = np.frombuffer(buf.read(), np.float32)
        return b[8:11].astype(float), b[12:15].astype(float)

    def _release_own(self) -> None:
        if self.texture is not None:
            for o in (self.texture, self.accumulator, self._fbo, self._target):
                o.release()
            self.bounds.release()
            self.texture = None
            self.bounds = None

    def release(self) -> None:   # no light-depth map: self.texture is the volume
        self._release_own()
        if self._sim_texture is not None:
            self._sim_texture.release()
            self._sim_texture = None

