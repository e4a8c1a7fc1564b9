"""What the passes share: the Frame they run on, uniform helpers and the hair draw."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import NamedTuple
from pathlib import Path

import moderngl
import numpy as np

from ...gpu.capabilities import get_capabilities
from ...gpu.glsl import program
from ...gpu import uniforms
from ...gpu.uniforms import write_uniform
from ..bindings import (B_DENSITY_BOX, B_STRAND_TABLE, TEX_ADSM, TEX_DENSITY, TEX_DOM, TEX_OSM_FIRST, TEX_RSM_DOM,
                        TEX_RSM_FLUX, TEX_RSM_GEOM, TEX_RSM_GRID, TEX_SHADOW_MAP, TEX_XDOM_FIRST, TEX_XSHADOW_FIRST)
from ..camera import mat_bytes
from ..coverage_lod import mean_width
from ..lights import MAX_LIGHTS, MAX_SHADOW_LIGHTS

HERE = Path(__file__).resolve().parent
RENDER_DIR = HERE.parent


@functools.lru_cache(maxsize=None)
def shader_path(name: str) -> Path:
    """``HERE / name``, made once (a Path join on every draw cost more than the lookup it served)."""
    return HERE / name


MAX_ISOLINES = 64

INTERPOLATION_IDS = {"catmull_rom": 0, "bspline": 1, "bezier": 2}
MULTI_IDS = {"single": 0, "multi": 1, "hybrid": 2}
SHADOW_IDS = {"none": 0, "shadow_map": 1, "deep_opacity": 2, "adsm": 3, "opacity_maps": 4, "density": 5}
TONE_IDS = {"aces": 0, "reinhard": 1, "none": 2}
# hair fragment passes
PASS_SHADE, PASS_SHADOW_DEPTH, PASS_DOM_DEPTH, PASS_DOM_OPACITY = 0, 1, 2, 3


def shadow_defines(ctx, settings, pcf: int | None = None) -> dict:
    """lighting.glsl's defines: SHADOWS (light 0's method), XSHADOWS (whether lights 1.. cast:
    0 compiles their look-ups out), PCF, the look-ups' PCF kernel (default the settings'
    ``pcf``, the hair's; the head passes ``head_pcf``), MS_FOOTPRINT (the multiple
    scattering's deep-opacity box, ``ms_shadow_footprint``) and XLIGHT_CONST (``ctx``'s: the
    extra lights' sampler arrays indexed by constants on a CPU rasteriser, lighting.glsl)."""
    return {"SHADOWS": SHADOW_IDS[settings.shadows], "XSHADOWS": int(int(settings.shadow_lights) > 1),
            "PCF": int(settings.pcf if pcf is None else pcf), "MS_FOOTPRINT": int(settings.ms_shadow_footprint),
            "XLIGHT_CONST": int(get_capabilities(ctx).is_software)}


SKIN_BOUNCE_SAMPLES = 16   # the skin bounce's gather samples per grid cell or shaded point (skin_bounce.py)
# The skin bounce's gather evaluated once a frame at the cells of a grid in light 0's space
# (skin_bounce_grid.comp) and read once, trilinear, by every shaded point; False: gathered at every
# shaded point (the oracle tests/test_render_skin_bounce.py holds the grid's frames against; H200: 0.7 ms slower in a
# 1080p close-up, docs/quality.md item (10); here, not in skin_bounce.py, which imports this module)
SKIN_BOUNCE_GRID = True


def skin_bounce_active(renderer) -> bool:
    """Whether the frame has the skin's bounce (skin_bounce.py): settings.skin_bounce > 0 and
    a head drawn."""
    s = renderer.settings
    return float(s.skin_bounce) > 0.0 and renderer.head is not None and bool(s.draw_head)


def bounce_defines(renderer) -> dict:
    """The hair shading programs' skin-bounce defines: SKIN_BOUNCE 1, SKIN_BOUNCE_SAMPLES and
    SKIN_BOUNCE_GRID (read the grid, or gather at every shaded point) where the
    term is on, else SKIN_BOUNCE 0 (the programs as they were without it)."""
    if not skin_bounce_active(renderer):
        return {"SKIN_BOUNCE": 0}
    return {"SKIN_BOUNCE": 1, "SKIN_BOUNCE_SAMPLES": SKIN_BOUNCE_SAMPLES, "SKIN_BOUNCE_GRID": int(SKIN_BOUNCE_GRID)}


class Target(NamedTuple):
    """A render target: its framebuffer, colour and depth attachments (Renderer.hdr_target)."""

    fbo: object
    color: object
    depth: object


@dataclass
class View:
    """A point of view for the hair's geometry shader (the camera or the key light)."""

    view_proj: np.ndarray
    eye: np.ndarray
    forward: np.ndarray
    ortho: bool
    pixel_size: float          # world size of a pixel: at unit depth (perspective) or anywhere (ortho)
    min_pixel_width: float

    def size_at(self, point) -> float:
        """The world size of a pixel (a map's texel) at ``point``."""
        if self.ortho:
            return float(self.pixel_size)
        return float(self.pixel_size) * float(np.linalg.norm(np.asarray(point, float) - self.eye))

    def uniforms(self) -> dict:
        """set_view's uniforms (made once: a view is not changed after it is made)."""
        u = self.__dict__.get("_uniforms")
        if u is None:
            u = self.__dict__["_uniforms"] = {
                "u_view_proj": mat_bytes(self.view_proj), "u_eye": tuple(map(float, self.eye)),
                "u_view_dir": tuple(map(float, self.forward)), "u_ortho": int(self.ortho),
                "u_pixel_size": float(self.pixel_size), "u_min_pixel_width": float(self.min_pixel_width)}
        return u


@dataclass
class Frame:
    """One frame's inputs and the targets the passes hand each other."""

    renderer: "object"
    camera: "object"
    lights: list
    view: View
    light_view: View | None = None
    hair_depth_range: tuple[float, float] = (0.0, 1.0)   # hair extent along the key light (m)
    shadow_views: list = field(default_factory=list)     # (View, depth range) of lights 1.. that cast
    index: int = 0
    still: int = 0   # the frame's place in a still scene's mean (passes/accumulate.py): 0 first or moving
    targets: dict = field(default_factory=dict)
    kept: list = field(default_factory=list)   # light-space passes whose last targets this frame reused
    memo: dict = field(default_factory=dict)   # uniforms the passes share, made once a frame


def same_box(a, b) -> bool:
    """Two (lo, hi) boxes equal (the strands keep their box object until refreshed; with
    instances the box is made anew each call)."""
    if a is b:
        return True
    if a is None or b is None:
        return False
    return bool(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]))


def _packable(u, value):
    """``value`` as write_uniform takes it for uniform ``u``: a 4x4 array as its bytes, another
    array as a tuple of floats, a list of vectors trimmed or zero-padded to the uniform's length."""
    cls = value.__class__
    if cls is np.ndarray:
        return mat_bytes(value) if value.shape == (4, 4) else tuple(map(float, value.reshape(-1)))
    if (cls is list or cls is tuple) and value and isinstance(value[0], (list, tuple, np.ndarray)):
        # the driver may trim an array to what the shader uses; a shorter list is zero-padded
        n = int(getattr(u, "array_length", len(value)) or len(value))
        vals = [tuple(map(float, v)) for v in value[:n]]
        vals += [(0.0,) * len(vals[0])] * (n - len(vals))
        return vals[0] if n == 1 else vals
    return value


def set_uniform(prog, name: str, value) -> bool:
    """Set a uniform if the program has it (the driver drops unused ones); False when absent.
    A value the uniform holds already is not written again (mane.gpu.uniforms): every write
    to a render program's uniform goes through here, ``set_uniforms`` or ``write_uniform``."""
    u = prog.get(name, None)
    if u is None:   # optimised away or not declared
        return False
    write_uniform(u, _packable(u, value))
    return True


def set_uniforms(prog, values: dict) -> None:
    """``set_uniform`` for every name of ``values`` (a dict not changed once made: a View's, a
    frame's lighting), through mane.gpu.uniforms.set_uniforms: the program's uniforms of the dict
    and their packed values found once per (program, dict), a uniform last written that very
    value object not looked at again."""
    uniforms.set_uniforms(prog, values, _packable)


def has_uniform(prog, name: str) -> bool:
    """Whether ``prog`` has the uniform (``name in prog`` walks every member of a moderngl program)."""
    return prog.get(name, None) is not None


def set_view(prog, view: View) -> None:
    set_uniforms(prog, view.uniforms())


def hair_program(renderer, pass_id: int, *, capture: bool = False, geometry: str | None = None,
                 fragment_file=None, geometry_file=None, extra_defines: dict | None = None, instance=None):
    """The hair program for ``pass_id``; a pass may bring its own fragment or geometry stage
    (same varyings as hair.geom / hair.tese) and defines; ``instance``: a program object of the
    caller's own (gpu.glsl.program)."""
    s = renderer.settings
    shading = renderer.shading
    geometry = geometry or s.geometry
    defines = {
        "INTERPOLATION": INTERPOLATION_IDS[s.interpolation],
        "GEOMETRY_LINES": int(geometry == "lines"),
        "PASS": pass_id,
        **shadow_defines(renderer.ctx, s),
        "CAPTURE": int(capture),
        "MULTI": MULTI_IDS[s.interpolation_mode],
        "LOD": int(bool(s.lod)),
        # the shading pass's lights' visibility from the strand points (hair_pull.vert, hair.geom)
        "VERTEX_SHADOWS": int(s.hair_shadow_lookup == "vertex" and pass_id == PASS_SHADE and geometry_file is None),
    }
    defines.update(shading.defines())
    if pass_id == PASS_SHADE:
        defines.update(bounce_defines(renderer))
    defines.update(extra_defines or {})
    frag = shader_path("hair.frag")
    if fragment_file is not None:
        frag = fragment_file
    if pulls(renderer, capture=capture, geometry_file=geometry_file):
        # pipeline="compute": vertex pulling from the expanded strands (passes/expand.py)
        prog = program(renderer.ctx, vertex=shader_path("hair_pull.vert"), fragment=frag, defines=defines,
                       include_dirs=[RENDER_DIR], instance=instance)
        prog.mane_pulls = True
        return prog
    geom = geometry_file if geometry_file is not None else shader_path("hair.geom")
    return program(renderer.ctx, vertex=shader_path("hair.vert"), tess_control=shader_path("hair.tesc"),
                   tess_evaluation=shader_path("hair.tese"), geometry=geom, fragment=frag,
                   defines=defines, include_dirs=[RENDER_DIR], instance=instance)


def pulls(renderer, *, capture: bool = False, geometry_file=None) -> bool:
    """Whether the hair is drawn from the expanded buffer (pipeline="compute"): not with a
    capture, a pass's own geometry stage or a hardware OIT method (those keep the tessellation
    pipeline). The distance LOD is expanded too (strand_expand.comp), once per camera position."""
    s = renderer.settings
    return (s.pipeline == "compute" and not capture
            and geometry_file is None and s.oit == "none")


def subdivisions(settings, points_per_strand: int) -> int:
    """Tessellated segments per guide segment so that a strand has at least ``settings.segments``."""
    return int(min(MAX_ISOLINES, max(1, math.ceil(settings.segments / max(1, points_per_strand - 1)))))


def draw_hair(renderer, prog, view: View, lod_eye=None, vao=None) -> None:
    """One draw of every guide's patches (instanced by 64 isolines); multi/hybrid
    interpolation: one patch per guide segment and group of 64 rendered strands. ``lod_eye``:
    where the distance LOD measures from (default: the renderer's camera of this frame). ``vao``:
    one with an index buffer draws the patches in its order (sorted blending)."""
    s = renderer.settings
    st = renderer.strands
    ctx = renderer.ctx
    N = st.points_per_strand
    set_view(prog, view)
    if getattr(prog, "mane_pulls", False):   # pipeline="compute"
        renderer.get_pass("expand").draw(prog, lines=(s.geometry == "lines"))
        return
    set_strand_uniforms(renderer, prog, view, lod_eye)
    st.bind()
    vao = vao if vao is not None else renderer.empty_vao(prog)
    ctx.patch_vertices = 4
    if s.interpolation_mode != "single":
        table = renderer.strand_table()
        table.buffer.bind_to_storage_buffer(B_STRAND_TABLE)
        set_uniform(prog, "u_num_render", int(table.count))
        groups = math.ceil(table.count / MAX_ISOLINES)
        vao.render(moderngl.PATCHES, vertices=groups * (N - 1) * 4, instances=1)
        return
    instances = math.ceil(int(s.strands_per_guide) / MAX_ISOLINES)
    vao.render(moderngl.PATCHES, vertices=st.num_segments * 4, instances=instances)


def set_strand_uniforms(renderer, prog, view: View | None = None, lod_eye=None) -> None:
    """The strand uniforms of strand_common.glsl / strand_eval.glsl (a program or compute shader)."""
    if lod_eye is None:
        lod_eye = getattr(renderer, "lod_eye", None)
    if lod_eye is None and view is not None:
        lod_eye = view.eye
    set_uniforms(prog, strand_uniforms(renderer, lod_eye))


def strand_uniforms(renderer, lod_eye=None) -> dict:
    """set_strand_uniforms' values: one dict while the settings object, the strands' shape and
    the LOD eye's values are the same (a simulator's frames expand every frame)."""
    s = renderer.settings
    st = renderer.strands
    eye = None if lod_eye is None else tuple(float(x) for x in lod_eye)
    key = (st.points_per_strand, st.num_guides, eye)
    memo = renderer.memo.get("strand_uniforms")
    if memo is not None and memo[0] is s and memo[1] == key:
        return memo[2]
    N = st.points_per_strand
    out = {name: int(value) for name, value in (
        ("u_n", N), ("u_num_guides", st.num_guides), ("u_strands_per_guide", int(s.strands_per_guide)),
        ("u_subdivisions", subdivisions(s, N)), ("u_keep_guide", int(s.keep_guide)))}
    out.update({name: float(value) for name, value in (
        ("u_clump_radius", s.clump_radius), ("u_clump_root", s.clump_root), ("u_clump_tip", s.clump_tip),
        ("u_stray_fraction", s.stray_fraction), ("u_stray_amount", s.stray_amount), ("u_width", s.width),
        ("u_width_tip", s.width_tip), ("u_curl_radius", s.curl_radius),
        ("u_strand_spread", math.radians(float(s.strand_spread))), ("u_curl_frequency", s.curl_frequency))})
    if eye is not None:
        out["u_lod_eye"] = eye
    out["u_lod_range"] = (float(s.lod_start), float(s.lod_end), float(s.lod_percent),
                          float(s.lod_width_multiplier) if s.lod else 1.0)
    out["u_lod_segments"] = (float(s.lod_segment_percent), float(s.lod_min_segments))
    out["u_segments"] = int(s.segments)
    renderer.memo["strand_uniforms"] = (s, key, out)
    return out


def bind_lighting(renderer, prog, frame: Frame) -> None:
    """Lights, ambient and light 0's shadow maps (texture units 1..3); the PCF kernel is the
    program's define (shadow_defines)."""
    set_uniforms(prog, _lighting_uniforms(renderer, frame))
    t = frame.targets
    if "shadow_map" in t:
        t["shadow_map"].use(TEX_SHADOW_MAP)
    if "dom" in t:
        t["dom"].use(TEX_DOM)
    bind_shadow_methods(renderer, prog, frame)
    bind_extra_shadows(renderer, prog, frame)
    rsm = t.get("skin_rsm")   # the skin's reflective shadow map and grid (skin_bounce.py), where made
    if rsm is not None:
        if rsm[4] is not None and has_uniform(prog, "u_bounce_grid"):
            rsm[4].use(TEX_RSM_GRID)
            set_uniforms(prog, rsm[3])
        elif has_uniform(prog, "u_rsm_flux"):
            rsm[0].use(TEX_RSM_FLUX)
            rsm[1].use(TEX_RSM_GEOM)
            rsm[2].use(TEX_RSM_DOM)
            set_uniforms(prog, rsm[3])


def _lighting_uniforms(renderer, frame: Frame) -> dict:
    """bind_lighting's uniforms, made once a frame, and kept from frame to frame while what they
    are made of (the lights, light 0's view (kept per scene box) and the hair's depth range
    along it, the settings, the maps the frame made) is the same: the same dict then lets
    set_uniforms skip its uniforms by identity."""
    memo = frame.memo.get("lighting")
    if memo is not None:
        return memo
    t = frame.targets
    try:
        key = (tuple(frame.lights), frame.hair_depth_range, "shadow_map" in t, "dom" in t)
        hash(key)
    except TypeError:   # an unhashable light: made for this frame only
        key = None
    kept = renderer.memo.get("lighting")
    if (key is not None and kept is not None and kept[0] == key and kept[1] is frame.light_view
            and kept[2] is renderer.settings):
        frame.memo["lighting"] = kept[3]
        return kept[3]
    out = _make_lighting_uniforms(renderer, frame)
    if key is not None:
        renderer.memo["lighting"] = (key, frame.light_view, renderer.settings, out)
    frame.memo["lighting"] = out
    return out


def _make_lighting_uniforms(renderer, frame: Frame) -> dict:
    lights = frame.lights[:MAX_LIGHTS]
    vecs, rads = [], []
    for light in lights:
        if light.is_point:
            vecs.append((*light.vector, 1.0))
        else:
            d = np.asarray(light.vector, float)
            d = d / np.linalg.norm(d)
            vecs.append((*d, 0.0))
        rads.append(tuple(float(c) * float(light.intensity) for c in light.color))
    while len(vecs) < MAX_LIGHTS:
        vecs.append((0.0, 1.0, 0.0, 0.0))
        rads.append((0.0, 0.0, 0.0))
    a = float(renderer.settings.ambient)
    out = {"u_num_lights": len(lights), "u_light_vec": vecs, "u_light_radiance": rads, "u_ambient": (a, a, a),
           "u_root_darkening": float(renderer.settings.root_darkening)}
    t = frame.targets
    if "shadow_map" in t:
        out["u_shadow_map"] = TEX_SHADOW_MAP
    if "dom" in t:
        out["u_dom"] = TEX_DOM
    lv = frame.light_view
    if lv is not None:
        s = renderer.settings
        texel = lv.size_at(renderer.scene_center())
        lo, hi = frame.hair_depth_range
        ext = max(hi - lo, 1e-4)
        out.update({"u_light_view_proj": mat_bytes(lv.view_proj), "u_light_eye": tuple(float(x) for x in lv.eye),
                    "u_light_dir": tuple(float(x) for x in lv.forward),
                    "u_shadow_bias": float(s.shadow_bias) * texel, "u_shadow_texel": float(texel),
                    "u_normal_offset": float(s.shadow_normal_offset), "u_slope_bias": float(s.shadow_slope_bias),
                    "u_shadow_density": float(s.shadow_density),
                    "u_dom_layers": tuple(float(f) * ext for f in s.dom_layers)})
    return out


def bind_extra_shadows(renderer, prog, frame: Frame) -> None:
    """Lights 1.. that cast shadows: their maps (units 16.. and 20..) and light views."""
    maps = frame.targets.get("extra_shadow_maps", [])
    doms = frame.targets.get("extra_doms", [])
    n = 1 + len(maps) if frame.light_view is not None else 0
    set_uniform(prog, "u_num_shadow_lights", n)
    if not has_uniform(prog, "u_xshadow_map"):
        return
    set_uniforms(prog, _extra_shadow_uniforms(renderer, frame, len(maps)))
    for k in range(MAX_SHADOW_LIGHTS):
        if 1 <= k <= len(maps):
            maps[k - 1].use(TEX_XSHADOW_FIRST + k)
            if k <= len(doms):
                doms[k - 1].use(TEX_XDOM_FIRST + k)
    set_uniforms(prog, _EXTRA_UNITS)


_EXTRA_UNITS = {"u_xshadow_map": [TEX_XSHADOW_FIRST + k for k in range(MAX_SHADOW_LIGHTS)],
                "u_xdom": [TEX_XDOM_FIRST + k for k in range(MAX_SHADOW_LIGHTS)]}


def _extra_shadow_uniforms(renderer, frame: Frame, num_maps: int) -> dict:
    """bind_extra_shadows' light views: the same dict while the views, their depth ranges and
    the settings are (set_uniforms then looks at it no more)."""
    views = frame.shadow_views[:num_maps]
    what = (renderer.settings, tuple(v for v, _ in views), tuple(d for _, d in views))
    memo = renderer.memo.get("extra_shadow_uniforms")
    if (memo is not None and memo[0][0] is what[0] and len(memo[0][1]) == len(what[1])
            and all(a is b for a, b in zip(memo[0][1], what[1])) and memo[0][2] == what[2]):
        return memo[1]
    s = renderer.settings
    center = renderer.scene_center()
    eyes, dirs, biases, layers = [(0.0, 0.0, 0.0)], [(0.0, 0.0, 1.0)], [0.0], [(1.0, 2.0, 3.0)]
    texels = [0.0]
    mats = [np.eye(4)]
    for k, (lv, (lo, hi)) in enumerate(frame.shadow_views[:num_maps]):
        mats.append(lv.view_proj)
        eyes.append(tuple(float(x) for x in lv.eye))
        dirs.append(tuple(float(x) for x in lv.forward))
        texel = lv.size_at(center)
        biases.append(float(s.shadow_bias) * texel)
        texels.append(float(texel))
        ext = max(hi - lo, 1e-4)
        layers.append(tuple(float(f) * ext for f in s.dom_layers))
    while len(mats) < MAX_SHADOW_LIGHTS:
        mats.append(np.eye(4)); eyes.append((0.0, 0.0, 0.0)); dirs.append((0.0, 0.0, 1.0))
        biases.append(0.0); layers.append((1.0, 2.0, 3.0)); texels.append(0.0)
    out = {
        "u_xlight_view_proj": b"".join(mat_bytes(m) for m in mats[:MAX_SHADOW_LIGHTS]),
        "u_xlight_eye": eyes[:MAX_SHADOW_LIGHTS], "u_xlight_dir": dirs[:MAX_SHADOW_LIGHTS],
        "u_xshadow_bias": biases[:MAX_SHADOW_LIGHTS], "u_xshadow_texel": texels[:MAX_SHADOW_LIGHTS],
        "u_xdom_layers": layers[:MAX_SHADOW_LIGHTS]}
    renderer.memo["extra_shadow_uniforms"] = (what, out)
    return out


def adsm_coverage(renderer, frame: Frame) -> float:
    """The part of a map texel one strand covers (its mean width over the texel, at most 1): the
    ADSM's fibre crossing passes exp(-shadow_density * strand_opacity * coverage), as a strand
    adds strand_opacity times its coverage alpha to the deep opacity and opacity maps' texels,
    instead of darkening the whole texel as an opaque fibre would."""
    s, lv = renderer.settings, frame.light_view
    if lv is None:
        return 1.0
    texel = lv.size_at(renderer.scene_center())
    return min(1.0, mean_width(s) / max(texel, 1e-12))


def bind_shadow_methods(renderer, prog, frame: Frame) -> None:
    """The ADSM, opacity shadow map and density look-ups' textures and uniforms (when made)."""
    s = renderer.settings
    t = frame.targets
    if "adsm" in t:
        t["adsm"].use(TEX_ADSM)
        set_uniform(prog, "u_adsm", TEX_ADSM)
        set_uniform(prog, "u_adsm_spacing", float(s.adsm_spacing) * float(s.width))
        set_uniform(prog, "u_adsm_tau", float(s.shadow_density) * float(s.strand_opacity) * adsm_coverage(renderer, frame))
    if "osm" in t:
        maps = t["osm"]
        for k, tex in enumerate(maps):
            tex.use(TEX_OSM_FIRST + k)
        try:
            n = max(int(prog["u_osm"].array_length), len(maps))
            set_uniform(prog, "u_osm", [TEX_OSM_FIRST + min(k, len(maps) - 1) for k in range(n)])
        except KeyError:
            pass
        set_uniform(prog, "u_osm_targets", len(maps))
        lo, hi = t["osm_range"]
        set_uniform(prog, "u_osm_range", (float(lo), float(hi)))
    if "density" in t:
        tex, box = t["density"]
        tex.use(TEX_DENSITY)
        box.bind_to_storage_buffer(B_DENSITY_BOX)
        set_uniform(prog, "u_density", TEX_DENSITY)
        set_uniform(prog, "u_density_step", float(s.density_step))


# ---------------------------------------------------------------- light-depth maps
FAR = 1.0e9   # light depth (m) of a texel no geometry reached


def light_depth_target(ctx, n: int):
    """An n x n R32F texture of linear light depth (nearest filtering), a depth renderbuffer and
    their framebuffer: (texture, depth, fbo)."""
    from ...gpu.buffers import check_texture

    check_texture(ctx, (n, n), 1, 4, f"a {n}x{n} light depth map", extra_bytes=n * n * 4,
                  reduce="Use a smaller shadow_map_size")
    texture = ctx.texture((n, n), 1, dtype="f4")
    texture.filter = (ctx.NEAREST, ctx.NEAREST)
    texture.repeat_x = texture.repeat_y = False   # gathers past the edge read the edge (shadow_pcf.glsl)
    depth = ctx.depth_renderbuffer((n, n))
    return texture, depth, ctx.framebuffer([texture], depth)


def begin_light_depth(ctx, fbo) -> None:
    """Bind a light-depth framebuffer, clear it to FAR, depth test on, blending off."""
    fbo.use()
    fbo.clear(FAR, FAR, FAR, FAR, depth=1.0)
    ctx.enable(ctx.DEPTH_TEST)
    ctx.disable(ctx.BLEND)


def read_f32(texture) -> np.ndarray:
    """A float32 texture as a (height, width) array, or (height, width, components)."""
    w, h = texture.size
    shape = (h, w) if texture.components == 1 else (h, w, texture.components)
    return np.frombuffer(texture.read(), np.float32).reshape(shape).copy()


class Pass:
    """A step of the frame. ``reads``/``writes`` name the frame targets (documentation and checks).
    ``light_space``: the pass's targets follow from the lights, the hair, the head and the
    settings, not from the camera (shadow and opacity maps, the skin's bounce): the renderer
    reuses its last targets (``kept``: (the LightKey they were made under, the targets the run
    published)) while the frame's key (render/light_key.py) matches it, instead of running it."""

    name = "pass"
    reads: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()
    light_space = False

    def __init__(self, renderer):
        self.renderer = renderer
        self.ctx = renderer.ctx
        self.kept = None

    def enabled(self, frame: Frame) -> bool:
        return True

    def run(self, frame: Frame) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def release(self) -> None:
        pass
