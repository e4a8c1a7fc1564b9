"""The renderer's buffer bindings, image units and texture units, declared once.

Every name here is injected into each GLSL source under ``mane/render`` as a ``#define`` by
``mane.gpu.glsl`` (``layout(std430, binding = B_EXPANDED)``), and the Python that binds the
objects uses the same constant (``buffer.bind_to_storage_buffer(B_EXPANDED)``). ``B_``: shader
storage buffers; ``IMG_``: image units; ``TEX_``: texture units. Numbers may repeat between
programs that never run together; within one program they must differ (tests/test_bindings.py
checks every program, branch by branch).
"""
from __future__ import annotations

from pathlib import Path

from ..gpu.glsl import register_bindings

# the strands (every strand program: strand_common.glsl, strand_expand.comp, the pullers)
B_POSITIONS = 0           # guide points (StrandBuffers)
B_FRAMES = 1              # their transported frames (guide_frames.comp)
B_STRAND_TABLE = 2        # multi / hybrid strand records (multi_strand.StrandTable)
B_EXPANDED = 3            # the expanded strands, 2 vec4 a point (strand_expand.comp)
# the density volume (density.py; the lighting's density shadow reads the box)
B_SIM_GRID = 4            # the simulator's friction grid, resampled by density_resolve.comp
B_DENSITY_ACC = 5         # fixed-point splat accumulator
B_DENSITY_BOX = 6         # the volume's box
# the hardware hair pass
B_CAPTURE = 7             # hair.geom's capture of the drawn geometry (capture.py)
# the compute rasteriser (hair_vis.glsl, hair_raster.comp, hair_shade.comp, aux_maps.comp)
B_VIS = 8                 # nearest (depth, segment) per sample; 32-bit path: depth
B_VIS_ID = 9              # 32-bit path: segment + 1
B_COVER = 10              # coverage sums
B_RASTER_STATS = 11       # hair_raster.comp's optional counters
B_AUX_OUT = 12            # aux_maps.comp's output
B_DEPTH_TILES = 18        # the scene depth's tile map (depth_tiles.comp; hair_raster.comp, oit_raster.comp)
B_TILE_COUNTS = 19        # the tiled scan conversion (raster_tiles.py): per-tile counts, then cursors
B_TILE_INDEX = 20         # its indirect dispatches, list offsets and non-empty tiles
B_TILE_ENTRIES = 21       # its per-tile lists of segments
# the head by compute (head_shade.comp): the head mesh's vertex and index buffers
B_HEAD_VERTICES = 22
B_HEAD_FACES = 23
# deep opacity maps by the compute rasteriser (dom_raster.comp, dom_pack.comp, shadow_merge.comp)
B_DOM_Z0 = 11
B_DOM_LAYERS = 12
# the shadow probe (shadow_probe.comp)
B_PROBE_POINTS = 2
B_PROBE_OUT = 3
# the BSDF harness (shading/harness.comp)
B_HARNESS_SAMPLES = 0
B_HARNESS_RESULTS = 1
# transparency, hardware fill (oit/*.glsl, oit/*.frag)
B_PPLL_NODES = 8
B_PPLL_COUNTER = 9
B_OIT_KEYS = 10           # K-buffer / random subsets / ShortCut keys (or depths)
B_OIT_COLORS = 11
B_SORT_KEYS = 12          # sorted blending (sort_keys.comp, bitonic.comp, sort_indices.comp)
B_SORT_INDICES = 13
# transparency, compute fill (oit_raster.comp, oit_resolve.comp)
B_OIT_HEADS = 10          # A-buffer: list heads, node pool, counter
B_OIT_NODES = 11
B_OIT_COUNTER = 12
B_OIT_SLOTS = 10          # K-buffer / DBK / ShortCut: slots, their ids, the tail sums
B_OIT_SLOT_IDS = 11
B_OIT_TAIL = 12
B_OIT_FRONT = 13          # DBK
B_OIT_BEHIND = 14
B_OIT_RECORDS = 15        # capture
B_OIT_MEASURE = 16
B_OIT_BEHIND_OPTICAL = 17

# image units
IMG_HDR = 0               # the HDR colour (hair_shade.comp, oit_resolve.comp)
IMG_SHADOW = 1            # the shadow map written by shadow_merge.comp
IMG_DOM = 1               # the deep opacity map written by dom_pack.comp
IMG_DENSITY = 0           # the density volume written by density_resolve.comp
IMG_OIT_HEADS = 0         # A-buffer heads (store_ppll.glsl, resolve_ppll.frag)
IMG_OIT_FRONT = 1         # DBK front depths
IMG_CLEAR = 0             # oit/clear.comp's image
IMG_OUTPUT = 1            # the 8-bit output written by resolve.comp
IMG_BOUNCE_GRID = 0       # the skin bounce's grid written by skin_bounce_grid.comp
IMG_ACCUM = 0             # a still scene's running mean (accumulate.comp)
IMG_MS = 1                # the multiply scattered light and the hair's coverage (hair_shade.comp -> ms_smooth.comp)
IMG_MS_SRC = 2            # ms_smooth.comp: the reduced grid a stage reads
IMG_MS_DST = 3            # ms_smooth.comp: the reduced grid a stage writes

# texture units
TEX_HDR = 0               # resolve.comp's input
TEX_SHADOW_MAP = 1
TEX_DOM = 2
TEX_DOM_Z0 = 3            # the hardware DOM's z0 map while its layers are drawn
TEX_ADSM = 4
TEX_DENSITY = 5
TEX_SCENE_DEPTH = 6       # the head's depth, read by the compute rasteriser
TEX_OSM_FIRST = 8         # opacity shadow maps: 8, 9, ...
TEX_XSHADOW_FIRST = 16    # extra lights' shadow maps: 17, 18, ... (16 + light)
TEX_XDOM_FIRST = 20       # and their deep opacity maps
TEX_OIT_RESOLVE = 0       # a resolve pass's first input (k_buffer, shortcut): 0, 1
TEX_MS_RESOLVE = 0        # sample_resolve.frag's multisampled input
TEX_LUT_DUAL = 7          # the shading model's tables (shading/__init__.py)
TEX_LUT_M = 24
TEX_LUT_N = 25
TEX_LUT_CHIANG = 26
TEX_LUT_CHIANG_NEAR = 24   # Chiang's near-field table (the Marschner LUT's unit: never in one program)
TEX_RSM_FLUX = 27           # the skin's reflective shadow map (passes/skin_bounce.py)
TEX_RSM_GEOM = 28
TEX_RSM_DOM = 29
TEX_HEAD_ID = 31           # the head's nearest triangle per pixel (head_shade.comp)
TEX_RSM_GRID = 30          # the skin bounce's grid (skin_bounce_grid.comp)

TABLE = register_bindings(Path(__file__).parent, globals())
