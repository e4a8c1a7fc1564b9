"""Hair-hair friction by grid velocity smoothing (Petrovic, Henne and Anderson 2005).

    friction = GridFriction(ctx, resolution=32, method="raster")
    friction.apply(positions, velocities, num_particles, friction=0.1)           # own bounds
    friction.apply(positions, velocities, num_particles, 0.1, bounds=bounds)     # shared GridBounds

Each step, on the GPU only:

1. **splat**: every particle adds its mass m and momentum m v to the 8 nodes of its cell
   with trilinear (tent) weights w = (1-|dx|)(1-|dy|)(1-|dz|) (Woodhouse §1.5, Petrovic):
   - ``method="atomic"``: ``atomicAdd`` into an SSBO accumulator (``grid_accum.glsl``) in
     one of two number formats, chosen from the context (``float_atomics=None``):
       * float32 ``atomicAdd`` where ``GL_NV_shader_atomic_float`` exists (NVIDIA, Mesa);
       * else 64-bit fixed point made of two 32-bit words (a carry from the low word goes to
         the high one). Each contribution is rounded to 2^-32 (of a mass unit, or mass unit *
         m/s); the sums are exact and independent of order; a node holds up to 2^31 mass units.
     and in one of two schedules (``splat=``):
       * ``"binned"`` (default up to 129^3 nodes): particles are counted and sorted by tile of
         8^3 cells (3 small dispatches; at scale the scatter copies each particle's position
         and velocity, side by side, to its sorted slot instead of writing the order), then each work group sums a balanced chunk
         of sorted particles, read contiguously from those copies, into its tile's 9^3 nodes
         in shared memory and adds only the touched nodes to the accumulator
         (``splat_binned.comp``).
         Gathering a tile's particles through the order instead (they come from strands all
         over the buffers) was the splat's whole cost at 1M guides (H200, friction at 1M / 2M
         guides x 32: 11.5 / 43.2 -> 5.8 / 11.6 ms), but cheaper up to 500k guides (16M
         particles: 1.96 against 2.35 ms), so the copies are made from ``SORTED_COPY_MIN``
         particles on (``sorted_copy`` forces either; docs/performance.md). Global atomics drop
         from 32 per particle to a few per tile node, so hot nodes (thousands of particles at the scalp) no longer
         serialise in L2. With float atomics (``aggregate``, on by default there) each
         invocation's run of sorted particles, mostly consecutive particles of a strand, is
         summed in registers while it stays in one cell, and goes to the tile when the cell
         changes: fewer shared atomics (faster: docs/performance.md), the same sums up to float
         rounding.
         ``cell_sort`` has each work group walk its chunk in cell order: per tile segment of the
         chunk, a shared histogram of the particles' cells within the tile (512), its scan and
         a shared permutation (16-bit offsets in the chunk), then each invocation sums a
         contiguous run of the cell-ordered particles, mostly of one cell, so a run of register
         sums spans a cell: about one flush of 32 shared atomics a run instead of about one a
         particle. The tile sort itself is unchanged. On by default where the sorted copies are made
         (from ``SORTED_COPY_MIN`` particles) with float sums.
       * ``"direct"``: one invocation per particle, 32 global atomics (64 in fixed point)
         (``splat_atomic.comp``).
   - ``method="raster"``: Woodhouse's ``optimised_gpu`` splat. Each particle's 8 corners are
     drawn as 1-pixel points on the ``gl_Layer`` slices of a layered RGBA32F 3D texture
     attached to a framebuffer (the vertex shader picks the layer where
     ``GL_ARB_shader_viewport_layer_array`` / ``GL_AMD_vertex_shader_layer`` exist; else a
     geometry shader emits the 8 points), and GL_ONE/GL_ONE additive blending sums (m v, m)
     in float32. Its cost is the blending: every point is a read-modify-write of a 16-byte
     RGBA32F pixel in primitive order, so the thousands of points that land on one node near
     the scalp are blended one after another: the draw is blend-bound, not geometry-bound, and
     two orders of magnitude slower than the binned atomic splat (docs/performance.md). Kept
     for comparison (Woodhouse 2017).
2. **normalise**: node velocity V = sum(m w v) / sum(m w) (zero where there is no mass).
3. **gather**: v <- (1 - f) v + f V(x), V(x) trilinear. Pinned particles (w = 0) keep their
   velocity (they still splat, with ``pinned_mass``).

The grid has ``resolution``^3 nodes spanning a :class:`~mane.sim.bounds.GridBounds` box:
node i at lo + i (hi - lo)/(R - 1). Masses are 1/w from ``positions.w`` in units of
``mass_unit`` (kg); only their ratios matter to the result.
"""
from __future__ import annotations

import ctypes
import math
from pathlib import Path

import numpy as np

from ..errors import GLFeatureError, UsageError
from ..gpu.context import is_software_renderer
from ..gpu.entry_points import gl_entry
from .bounds import (BOUNDS_BINDING, GridBounds, check_particle_buffers, groups, is_state,
                     set_uniforms, storage_barrier)
from .bindings import (B_ACCUMULATOR, B_GRID, B_ORDER, B_PARTICLE_VELOCITIES, B_POSITIONS, B_SORTED, B_TILES,
                       TEX_SPLAT)

HERE = Path(__file__).resolve().parent
METHODS = ("atomic", "raster")
SPLATS = ("binned", "direct")
FLOAT_ATOMICS_EXTENSION = "GL_NV_shader_atomic_float"
VERTEX_LAYER_EXTENSIONS = ("GL_ARB_shader_viewport_layer_array", "GL_AMD_vertex_shader_layer")
TILE_CELLS = 8        # binned splat: a tile is 8^3 cells, 9^3 nodes in shared memory
MAX_TILES_AXIS = 16   # 4096 tiles (the count / scatter stages keep a shared histogram of them)
PPT = 4               # binned count / scatter: particles per invocation
SOFTWARE_MAX_CHUNK = 2048  # binned splat on llvmpipe: its loop limiter (gallivm) ends a shader after
                           # 65,535 iterations of all its loops together, and a chunk walks up to
                           # ~18 a tile segment: 8,000 particles spread over a 129^3 grid in chunks of
                           # 8,192 summed 5,071 of their 8,000 mass units, with no error
SORTED_COPY_MIN = 20_000_000  # binned splat: particles from which the scatter copies them in sorted
                              # order for the splat (H200, friction pass without / with the copies,
                              # guides x 32: 100k 0.40 / 0.50 ms, 250k 0.91 / 1.15, 500k 1.96 / 2.35,
                              # 1M 7.9 / 4.75, 2M 32.1 / 9.5; docs/performance.md)
CHUNK = 512           # binned splat: sorted particles per work group (H200, splat stage at 1M / 2M
                      # guides x 32 from the sorted copies: 2.98 / 5.91 ms at 512, 3.95 / 7.86 at
                      # 256, 2.83 / 5.58 at 1024, 2.84 / 5.61 at 2048; docs/performance.md)
CELL_RUN = 16         # cell-ordered binned splat: slots per invocation (its chunk is 256 x this). H200,
                      # 1M / 2M guides x 32, splat stage: tile order 2.94 / 5.84 ms, cell order at runs
                      # of 16 1.78 / 3.30, of 32 2.96 / 5.37 (31 KB of shared memory a group: fewer
                      # groups resident); docs/performance.md
MAX_CELL_CHUNK = 256 * 32   # cell-ordered chunks at most (its shared permutation: 2 bytes a slot)
SOFTWARE_CELL_CHUNK = 512  # cell-ordered chunks by default on llvmpipe (its loop limiter, as for
                           # SOFTWARE_MAX_CHUNK: the cell walk loops more a tile segment)
SPREAD_FLUSH = True   # cell-ordered binned splat: each lane starts its flush of a run's 32 shared
                      # atomics at another (corner, word), so a warp's lanes in one cell do not meet


def _shared_limit(ctx) -> int:
    """GL_MAX_COMPUTE_SHARED_MEMORY_SIZE, bytes (GL 4.3's minimum, 32 KiB, where unreadable)."""
    try:
        from ..gpu.capabilities import get_capabilities

        return int(get_capabilities(ctx).limits.get("max_compute_shared_memory_size") or 32768)
    except Exception:
        return 32768


def _cell_chunk_problem(ctx, chunk: int, float_atomics: bool) -> str | None:
    """Why the cell-ordered splat cannot take chunks of ``chunk`` slots here, or None."""
    if chunk % 256 or chunk > MAX_CELL_CHUNK:
        return f"takes a chunk that is a multiple of 256 up to {MAX_CELL_CHUNK}"
    need, limit = cell_splat_shared_bytes(chunk, float_atomics), _shared_limit(ctx)
    if need > limit:
        return f"needs {need} bytes of shared memory, more than this OpenGL's {limit}; use a smaller chunk"
    return None


def cell_splat_shared_bytes(chunk: int, float_atomics: bool) -> int:
    """Shared memory of the cell-ordered splat stage: the node tile ((TILE_CELLS + 1)^3 nodes of
    4 floats or 8 fixed-point words), the 512 cell counts, the 256 scan sums and the permutation
    (2 bytes a slot)."""
    return (TILE_CELLS + 1) ** 3 * (4 if float_atomics else 8) * 4 + (TILE_CELLS ** 3 + 256) * 4 + chunk * 2


def _extensions(ctx) -> frozenset:
    try:
        from ..gpu.capabilities import get_capabilities

        return get_capabilities(ctx).extensions
    except Exception:  # capabilities unavailable: what moderngl lists
        return frozenset(getattr(ctx, "extensions", ()) or ())
METHOD_ALIASES = {"splat": "atomic", "scatter": "atomic", "gpu": "atomic",
                  "rasterize": "raster", "rasterise": "raster", "optimised_gpu": "raster",
                  "optimized_gpu": "raster"}

# --------------------------------------------------------------------------- raw GL for layered FBOs
GL_FRAMEBUFFER = 0x8D40
GL_COLOR_ATTACHMENT0 = 0x8CE0
GL_FRAMEBUFFER_COMPLETE = 0x8CD5


def _gl(name: str, restype, *argtypes):
    """A core GL entry point (mane.gpu.entry_points); GLFeatureError where there is none."""
    fn = gl_entry(name, restype, *argtypes)
    if fn is None:
        raise GLFeatureError(f"cannot find the OpenGL function {name} (needed for the layered "
                             f"3D-texture framebuffer of GridFriction(method='raster')); use method='atomic'")
    return fn


def layered_framebuffer(ctx, texture3d):
    """A moderngl Framebuffer whose colour attachment is all layers of ``texture3d``."""
    gen = _gl("glGenFramebuffers", None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint))
    bind = _gl("glBindFramebuffer", None, ctypes.c_uint, ctypes.c_uint)
    attach = _gl("glFramebufferTexture", None, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_int)
    draw_buffers = _gl("glDrawBuffers", None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint))
    status = _gl("glCheckFramebufferStatus", ctypes.c_uint, ctypes.c_uint)
    previous = ctx.fbo
    fbo = ctypes.c_uint(0)
    gen(1, ctypes.byref(fbo))
    bind(GL_FRAMEBUFFER, fbo.value)
    attach(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, texture3d.glo, 0)
    bufs = (ctypes.c_uint * 1)(GL_COLOR_ATTACHMENT0)
    draw_buffers(1, bufs)
    code = status(GL_FRAMEBUFFER)
    if code != GL_FRAMEBUFFER_COMPLETE:
        bind(GL_FRAMEBUFFER, 0)
        raise GLFeatureError(f"the layered 3D-texture framebuffer is incomplete (status 0x{code:04x}); "
                             "use GridFriction(method='atomic')")
    framebuffer = ctx.detect_framebuffer(fbo.value)
    if previous is not None:
        previous.use()
    return framebuffer, fbo.value


def delete_framebuffer(glo: int) -> None:
    delete = _gl("glDeleteFramebuffers", None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint))
    delete(1, ctypes.byref(ctypes.c_uint(glo)))


# --------------------------------------------------------------------------- GridFriction
class GridFriction:
    """Velocity smoothing on a ``resolution``^3 node grid (16..128; see the module docstring).

    mass_unit: kg that one unit of grid mass stands for (the fixed-point range and
    resolution are in this unit). pinned_mass: kg a pinned particle (w = 0) brings to the
    grid (0 leaves pinned particles out). bounds_*: settings of the GridBounds made when
    ``apply`` gets no ``bounds``.

    Binned splat only: ``chunk``: sorted slots per work group (default ``CHUNK``; with
    ``cell_sort`` 256 x ``CELL_RUN``, shortened until the splat's shared memory fits, or
    ``SOFTWARE_CELL_CHUNK`` on llvmpipe; a multiple of 256 up to ``MAX_CELL_CHUNK``). ``aggregate``:
    register sums of a run's particles in one cell (float atomics only; on there by default).
    ``sorted_copy``: the scatter copies the particles in sorted order for the splat (default from
    ``SORTED_COPY_MIN`` particles on). ``cell_sort``: each work group walks its chunk in cell
    order. None (the default): the splats that make the sorted copy do, with float sums
    (``copy_cell_sort``, chunks of ``copy_chunk``); True: every splat does, and it turns the
    sorted copy on whatever the size (the cell order reads a
    chunk's slots out of order, cheap in the copies; ``sorted_copy=False`` still works, reading
    them through the order). It pays only with ``aggregate``; with fixed-point sums it is correct
    (the same exact sums) but no faster.
    """

    def __init__(self, ctx, resolution: int = 32, method: str = "atomic", *,
                 mass_unit: float = 1.0, pinned_mass: float = 1.0,
                 bounds_margin: float = 0.0, bounds_relative_margin: float = 0.05,
                 bounds_cubic: bool = True, float_atomics: bool | None = None,
                 splat: str | None = None, chunk: int | None = None, vertex_layer: bool | None = None,
                 aggregate: bool | None = None, sorted_copy: bool | None = None,
                 cell_sort: bool | None = None):
        from ..gpu.glsl import compute_shader, program

        for name, value in (("float_atomics", float_atomics), ("vertex_layer", vertex_layer),
                            ("aggregate", aggregate), ("sorted_copy", sorted_copy), ("cell_sort", cell_sort)):
            if value is not None and not isinstance(value, (bool, np.bool_)):
                raise UsageError(f"GridFriction {name} must be true, false or None (the GPU's choice), got {value!r}")
        if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, float, np.integer, np.floating))
                                  or not math.isfinite(chunk) or chunk != int(chunk)):
            raise UsageError(f"GridFriction chunk must be a whole number of particles, got {chunk!r}")
        resolution = int(resolution)
        if not 2 <= resolution <= 512:
            raise UsageError(f"GridFriction resolution must be in 2..512 (16..128 is usual), got {resolution}")
        method = METHOD_ALIASES.get(method, method)
        if method not in METHODS:
            raise UsageError(f"GridFriction method must be one of {METHODS}, got {method!r}")
        if mass_unit <= 0 or pinned_mass < 0:
            raise UsageError("GridFriction: mass_unit must be > 0 and pinned_mass >= 0")
        self.ctx = ctx
        self.resolution = resolution
        self.method = method
        self.mass_unit = float(mass_unit)
        self.pinned_mass = float(pinned_mass)
        self.num_nodes = resolution ** 3
        exts = _extensions(ctx)
        defines = {"GRID_RES": resolution, "BOUNDS_BINDING": BOUNDS_BINDING}
        self._own_bounds = GridBounds(ctx, margin=bounds_margin, relative_margin=bounds_relative_margin,
                                      cubic=bounds_cubic)
        self.bounds: GridBounds = self._own_bounds
        from ..gpu.buffers import check_allocation

        # the grid and (at most) its accumulator / 3D texture, before any is made
        check_allocation(ctx, self.num_nodes * 48, f"the friction grid of {resolution}^3 nodes", ssbo=False,
                         reduce="Use a smaller grid_resolution")
        self.grid = ctx.buffer(reserve=self.num_nodes * 16)        # vec4(v, mass) per node
        self._gather = compute_shader(ctx, HERE / "grid_gather.comp", defines)
        self.float_atomics = False
        self.splat_schedule = None
        self.vertex_layer = False
        self.aggregate = False
        # True: every binned splat in cell order (the sorted copy forced on); None: the splats that
        # make the sorted copy, with float sums (where it was measured); False: none
        self.cell_sort = cell_sort if cell_sort is None else bool(cell_sort)
        if self.cell_sort and (method != "atomic" or splat == "direct"):
            raise UsageError("GridFriction(cell_sort=True) orders the binned splat's chunks by cell; it needs "
                             "method='atomic' and splat='binned'")
        if method == "atomic":
            has_float = FLOAT_ATOMICS_EXTENSION in exts
            if float_atomics is None:
                float_atomics = has_float
            elif float_atomics and not has_float:
                raise GLFeatureError(f"GridFriction(float_atomics=True) needs {FLOAT_ATOMICS_EXTENSION}, "
                                     "which this OpenGL lacks; leave float_atomics=None for fixed point")
            self.float_atomics = bool(float_atomics)
            tiles_axis = -(-(resolution - 1) // TILE_CELLS)
            if splat is None:
                splat = "binned" if tiles_axis <= MAX_TILES_AXIS else "direct"
            if splat not in SPLATS:
                raise UsageError(f"GridFriction splat must be one of {SPLATS}, got {splat!r}")
            if splat == "binned" and tiles_axis > MAX_TILES_AXIS:
                raise UsageError(f"the binned splat takes resolutions up to "
                                 f"{MAX_TILES_AXIS * TILE_CELLS + 1}; use splat='direct'")
            if self.cell_sort and splat != "binned":
                raise UsageError(f"GridFriction(cell_sort=True) needs the binned splat, which takes "
                                 f"resolutions up to {MAX_TILES_AXIS * TILE_CELLS + 1}")
            if chunk is not None:
                cell_chunk = int(chunk)
            else:
                # 256 x CELL_RUN, or the longest multiple of 256 whose shared memory fits (fixed
                # point's node tile is twice float's: 23 KB; llvmpipe allows 32 KB, NVIDIA 48 KB)
                limit = _shared_limit(ctx)
                cell_chunk = SOFTWARE_CELL_CHUNK if is_software_renderer(ctx) else 256 * CELL_RUN
                while cell_chunk > 256 and cell_splat_shared_bytes(cell_chunk, self.float_atomics) > limit:
                    cell_chunk -= 256
                chunk = cell_chunk if self.cell_sort else CHUNK
            if int(chunk) < 256:
                raise UsageError("GridFriction chunk must be >= 256 particles")
            cell_problem = _cell_chunk_problem(ctx, cell_chunk, self.float_atomics)
            if self.cell_sort and cell_problem:
                raise UsageError(f"GridFriction(cell_sort=True, chunk={cell_chunk}) {cell_problem}")
            if int(chunk) > SOFTWARE_MAX_CHUNK and is_software_renderer(ctx):
                raise UsageError(f"GridFriction chunk {int(chunk)} is over {SOFTWARE_MAX_CHUNK} on a CPU rasteriser, "
                                 f"which stops a shader after 65,535 loop iterations and would drop particles")
            self.splat_schedule = splat
            self.chunk = int(chunk)
            words = 4 if self.float_atomics else 8
            acc_defines = dict(defines, ACC_FLOAT=int(self.float_atomics))
            # created zeroed on the GPU side: never clear it with Buffer.clear(), which maps it
            # for CPU writes (after that NVIDIA's driver keeps it in system memory: 60x slower)
            self.accumulator = ctx.buffer(bytes(self.num_nodes * words * 4))
            if splat == "binned":
                self.num_tiles = tiles_axis ** 3
                self._tiles = ctx.buffer(bytes((3 * self.num_tiles + 1) * 4))
                self._order = self._sorted = None
                self._order_capacity = 0
                # float sums only; on by default there
                self.aggregate = self.float_atomics and (aggregate is None or bool(aggregate))
                # the sorted-copy path's splat in cell order: always with cell_sort, and by default
                # with float sums (H200, 1M guides x 32: friction splat 5.02 -> 3.84 ms, the step
                # 9.5 -> 8.3; docs/performance.md)
                self.copy_cell_sort = bool(self.cell_sort) or (self.cell_sort is None and self.aggregate
                                                               and cell_problem is None)
                self.copy_chunk = cell_chunk if self.copy_cell_sort else self.chunk
                binned = dict(acc_defines, TILE_CELLS=TILE_CELLS, TILES_AXIS=tiles_axis, PPT=PPT,
                              CHUNK=self.chunk, AGGREGATE=int(self.aggregate))
                if self.cell_sort:
                    binned.update(CELL_SORT=1, SPREAD_FLUSH=int(SPREAD_FLUSH))
                self._stages = {name: compute_shader(ctx, HERE / "splat_binned.comp",
                                                     dict(binned, **{f"STAGE_{name.upper()}": 1}))
                                for name in ("count", "scan", "scatter", "splat")}
                self._binned_defines = binned
                self._copy_stages = None    # the stages with the scatter and splat of SORTED_COPY, made when first used
                self.sorted_copy = None if sorted_copy is None else bool(sorted_copy)
            else:
                self._splat = compute_shader(ctx, HERE / "splat_atomic.comp", acc_defines)
            self._normalize = compute_shader(ctx, HERE / "grid_normalize.comp",
                                             dict(acc_defines, METHOD_ATOMIC=1))
        else:
            self.texture = ctx.texture3d((resolution,) * 3, 4, dtype="f4")
            self._fbo, self._fbo_glo = layered_framebuffer(ctx, self.texture)
            layer_ext = next((e for e in VERTEX_LAYER_EXTENSIONS if e in exts), None)
            if vertex_layer is None:
                vertex_layer = layer_ext is not None
            elif vertex_layer and layer_ext is None:
                raise GLFeatureError("GridFriction(vertex_layer=True) needs one of "
                                     f"{', '.join(VERTEX_LAYER_EXTENSIONS)}")
            self.vertex_layer = bool(vertex_layer)
            if self.vertex_layer:
                self._raster = program(ctx, vertex=HERE / "splat_raster_layer.vert",
                                       fragment=HERE / "splat_raster.frag",
                                       defines=dict(defines, **{f"USE_{layer_ext}": 1}))
            else:
                self._raster = program(ctx, vertex=HERE / "splat_raster.vert", geometry=HERE / "splat_raster.geom",
                                       fragment=HERE / "splat_raster.frag", defines=defines)
            self._vao = ctx.vertex_array(self._raster, [])
            self._normalize = compute_shader(ctx, HERE / "grid_normalize.comp",
                                             dict(defines, METHOD_ATOMIC=0))
        self._clear = compute_shader(ctx, HERE / "grid_clear.comp", {})

    @property
    def own_bounds(self) -> GridBounds:
        """The box ``splat`` updates when it gets no ``bounds`` (the simulator fills it itself)."""
        return self._own_bounds

    def _run(self, stage: str, shader, groups_x: int) -> None:
        """One dispatch of a stage (the benchmark wraps this to time each stage)."""
        shader.run(group_x=int(groups_x))

    # ------------------------------------------------------------------ steps
    def splat(self, positions, velocities, num_particles: int, bounds: GridBounds | None = None) -> None:
        """Clear, splat and normalise: leaves vec4(V, mass) per node in ``self.grid``."""
        n = check_particle_buffers(num_particles, positions, velocities)
        if bounds is None:
            bounds = self._own_bounds
            bounds.update(positions, n)
        self.bounds = bounds
        ctx = self.ctx
        bounds.bind()
        positions.bind_to_storage_buffer(B_POSITIONS)
        velocities.bind_to_storage_buffer(B_PARTICLE_VELOCITIES)
        masses = dict(pinned_mass=self.pinned_mass / self.mass_unit, inv_mass_unit=1.0 / self.mass_unit)
        if self.method == "atomic":
            self.accumulator.bind_to_storage_buffer(B_ACCUMULATOR)
            if n and self.splat_schedule == "binned":
                self._binned_splat(n, masses)
            elif n:
                set_uniforms(self._splat, num_particles=n, **masses)
                self._run("splat", self._splat, groups(n, 128))
                storage_barrier(ctx)
        else:
            self._raster_splat(n, masses)
        self.grid.bind_to_storage_buffer(B_GRID)
        set_uniforms(self._normalize, min_mass=1e-30)
        if self.method == "atomic":
            self.accumulator.bind_to_storage_buffer(B_ACCUMULATOR)
        else:
            self.texture.use(TEX_SPLAT)
            set_uniforms(self._normalize, splat_texture=TEX_SPLAT)
        self._run("normalise", self._normalize, groups(self.num_nodes, 256))
        storage_barrier(ctx)

    def uses_sorted_copy(self, n: int) -> bool:
        """Whether the binned splat of ``n`` particles copies them in sorted order first:
        ``sorted_copy`` when given, else with ``cell_sort`` or from ``SORTED_COPY_MIN`` particles on."""
        if self.sorted_copy is not None:
            return self.sorted_copy
        return bool(self.cell_sort) or n >= SORTED_COPY_MIN

    def _binned_splat(self, n: int, masses: dict) -> None:
        """count -> scan -> scatter -> splat (splat_binned.comp); leaves the sums in the accumulator."""
        ctx = self.ctx
        copy = self.uses_sorted_copy(n)
        stages = self._stages
        if copy:
            if self._copy_stages is None:
                from ..gpu.glsl import compute_shader

                copy_defines = dict(self._binned_defines, SORTED_COPY=1, CHUNK=self.copy_chunk)
                if self.copy_cell_sort:
                    copy_defines.update(CELL_SORT=1, SPREAD_FLUSH=int(SPREAD_FLUSH))
                self._copy_stages = dict(stages, **{name: compute_shader(
                    ctx, HERE / "splat_binned.comp", dict(copy_defines, **{f"STAGE_{name.upper()}": 1}))
                    for name in ("scatter", "splat")})
            stages = self._copy_stages
        if self._order_capacity < n or (copy and self._sorted is None):   # (re)made together
            from ..gpu.buffers import check_allocation

            self._release_order()
            capacity = max(n, 1024)
            record = 32   # the sorted copy: a particle's position and velocity, side by side
            if copy:   # and the order (8 bytes a particle)
                what = f"the friction splat's sorted copy of {n} particles"
                reduce = "Use fewer strands or points per strand"
                check_allocation(ctx, capacity * (8 + record), what, ssbo=False, reduce=reduce)
                check_allocation(ctx, capacity * record, what, reduce=reduce)     # the copies' buffer
            self._order_capacity = capacity
            self._order = ctx.buffer(reserve=2 * capacity * 4)
            if copy:
                self._sorted = ctx.buffer(reserve=capacity * record)
        self._tiles.bind_to_storage_buffer(B_TILES)
        self._order.bind_to_storage_buffer(B_ORDER)
        if copy:
            self._sorted.bind_to_storage_buffer(B_SORTED)
        per_group = 256 * PPT
        for name in ("count", "scan", "scatter", "splat"):
            sh = stages[name]
            set_uniforms(sh, num_particles=n, **masses)
            count = {"count": groups(n, per_group), "scan": 1, "scatter": groups(n, per_group),
                     "splat": groups(n, self.copy_chunk if copy else self.chunk)}[name]
            self._run(name, sh, count)
            storage_barrier(ctx)

    def clear_accumulator(self) -> None:
        """Zero the atomic accumulator on the GPU (``splat``'s normalise already leaves it zero;
        this is for the benchmark's explicit clear and for recovery). Never ``Buffer.clear()``:
        moderngl maps the buffer for it, and NVIDIA's driver then moves it to system memory."""
        if self.method != "atomic":
            return
        words = self.accumulator.size // 4
        self.accumulator.bind_to_storage_buffer(B_ACCUMULATOR)
        set_uniforms(self._clear, num_words=words)
        self._run("clear", self._clear, groups(words, 256))
        storage_barrier(self.ctx)

    def _raster_splat(self, n: int, masses: dict) -> None:
        import moderngl

        ctx = self.ctx
        saved = (ctx.viewport, ctx.point_size)
        # the scope restores the bound framebuffer and the enable flags on exit; the blend
        # function and equation (which moderngl cannot read back) are left at their defaults
        with ctx.scope(self._fbo, enable_only=moderngl.BLEND):
            ctx.viewport = (0, 0, self.resolution, self.resolution)
            self._fbo.clear(0.0, 0.0, 0.0, 0.0)
            if n:
                ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)
                set_uniforms(self._raster, **masses)
                ctx.blend_func = moderngl.ONE, moderngl.ONE
                ctx.blend_equation = moderngl.FUNC_ADD
                ctx.point_size = 1.0
                if self.vertex_layer:   # 8 corner points per particle, layer set by the vertex shader
                    self._run_render(moderngl.POINTS, 8 * n)
                else:                   # 1 point per particle, 8 emitted by the geometry shader
                    self._run_render(moderngl.POINTS, n)
        ctx.viewport, ctx.point_size = saved
        ctx.blend_func = moderngl.DEFAULT_BLENDING
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.FRAMEBUFFER_BARRIER_BIT)

    def _run_render(self, mode, vertices: int) -> None:
        self._vao.render(mode=mode, vertices=int(vertices))

    def gather(self, positions, velocities, num_particles: int, friction: float) -> None:
        """v <- (1 - friction) v + friction V(x) with the grid left by the last ``splat``."""
        n = check_particle_buffers(num_particles, positions, velocities)
        if not n:
            return
        self.bounds.bind()
        positions.bind_to_storage_buffer(B_POSITIONS)
        velocities.bind_to_storage_buffer(B_PARTICLE_VELOCITIES)
        self.grid.bind_to_storage_buffer(B_GRID)
        set_uniforms(self._gather, num_particles=n, friction=float(friction))
        self._run("gather", self._gather, groups(n, 128))
        storage_barrier(self.ctx)

    def apply(self, positions, *args, **kwargs) -> None:
        """One smoothing step in place on ``velocities`` (vec4, w kept). friction in [0, 1].

        ``apply(positions, velocities, num_particles, friction, bounds=None)`` or
        ``apply(state, friction, bounds=None)`` with a SimState.
        """
        if is_state(positions):
            st = positions
            return self._apply(st.positions, st.velocities, st.num_particles, *args, **kwargs)
        return self._apply(positions, *args, **kwargs)

    def _apply(self, positions, velocities, num_particles: int, friction: float,
               bounds: GridBounds | None = None) -> None:
        friction = float(friction)
        if not 0.0 <= friction <= 1.0:
            raise UsageError(f"grid friction must be in [0, 1], got {friction}")
        self.splat(positions, velocities, num_particles, bounds)
        if friction > 0.0:
            self.gather(positions, velocities, num_particles, friction)

    # ------------------------------------------------------------------ readback (tests, debugging)
    def read_grid(self) -> dict:
        """density (R,R,R) mass units, velocity and momentum (R,R,R,3), indexed [x, y, z]."""
        R = self.resolution
        g = np.frombuffer(self.grid.read(), dtype=np.float32).reshape(R, R, R, 4)  # [z, y, x]
        g = g.transpose(2, 1, 0, 3)
        density = g[..., 3].copy()
        velocity = g[..., :3].copy()
        return {"density": density, "velocity": velocity, "momentum": velocity * density[..., None]}

    def _release_order(self) -> None:
        """The binned splat's order and sorted copies, released (made again when next needed)."""
        for b in (self._order, self._sorted):
            if b is not None:
                b.release()
        self._order = self._sorted = None
        self._order_capacity = 0

    def release(self) -> None:
        self.grid.release()
        self._own_bounds.release()
        if self.method == "atomic":
            self.accumulator.release()
            if self.splat_schedule == "binned":
                self._tiles.release()
                self._release_order()
        else:
            self._vao.release()
            self._fbo.release()
            delete_framebuffer(self._fbo_glo)
            self.texture.release()
