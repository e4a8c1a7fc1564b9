"""What the passes share: the Frame they run on, uniform helpers and the hair draw."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import moderngl
import numpy as np

from ...gpu.glsl import program
from ..camera import mat_bytes

HERE = Path(__file__).resolve().parent
RENDER_DIR = HERE.parent
MAX_ISOLINES = 64

INTERPOLATION_IDS = {"catmull_rom": 0, "bspline": 1, "bezier": 2}
SHADOW_IDS = {"none": 0, "shadow_map": 1, "deep_opacity": 2}
TONE_IDS = {"aces": 0, "reinhard": 1, "none": 2}
# hair fragment passes
PASS_SHADE, PASS_SHADOW_DEPTH, PASS_DOM_DEPTH, PASS_DOM_OPACITY = 0, 1, 2, 3


@dataclass
class View:
    """A point of view for the hair's geometry shader (the camera or the key light)."""

    view_proj: np.ndarray
    eye: np.ndarray
    forward: np.ndarray
    ortho: bool
    pixel_size: float          # world size of a pixel: at unit depth (perspective) or anywhere (ortho)
    min_pixel_width: float


@dataclass
class Frame:
    """One frame's inputs and the targets the passes hand each other."""

    renderer: "object"
    camera: "object"
    lights: list
    view: View
    light_view: View | None = None
    hair_depth_range: tuple[float, float] = (0.0, 1.0)   # hair extent along the key light (m)
    index: int = 0
    targets: dict = field(default_factory=dict)


def set_uniform(prog, name: str, value) -> bool:
    """Set a uniform if the program has it (the driver drops unused ones); False when absent."""
    try:
        u = prog[name]
    except KeyError:
        return False
    if isinstance(value, np.ndarray) and value.shape == (4, 4):
        u.write(mat_bytes(value))
    elif isinstance(value, np.ndarray):
        u.value = tuple(float(x) for x in value.reshape(-1))
    elif isinstance(value, (list, tuple)) and value and isinstance(value[0], (list, tuple, np.ndarray)):
        u.value = [tuple(float(x) for x in v) for v in value]
    else:
        u.value = value
    return True


def set_view(prog, view: View) -> None:
    set_uniform(prog, "u_view_proj", view.view_proj)
    set_uniform(prog, "u_eye", tuple(float(x) for x in view.eye))
    set_uniform(prog, "u_view_dir", tuple(float(x) for x in view.forward))
    set_uniform(prog, "u_ortho", int(view.ortho))
    set_uniform(prog, "u_pixel_size", float(view.pixel_size))
    set_uniform(prog, "u_min_pixel_width", float(view.min_pixel_width))


def hair_program(renderer, pass_id: int, *, capture: bool = False, geometry: str | None = None):
    s = renderer.settings
    shading = renderer.shading
    geometry = geometry or s.geometry
    defines = {
        "INTERPOLATION": INTERPOLATION_IDS[s.interpolation],
        "GEOMETRY_LINES": int(geometry == "lines"),
        "PASS": pass_id,
        "SHADOWS": SHADOW_IDS[s.shadows],
        "CAPTURE": int(capture),
        "HAIR_MATERIAL_DECLARED": int(shading.declares_material),
    }
    defines.update(shading.defines())
    frag = HERE / ("hair_fallback.frag" if shading.fallback else "hair.frag")
    return program(renderer.ctx, vertex=HERE / "hair.vert", tess_control=HERE / "hair.tesc",
                   tess_evaluation=HERE / "hair.tese", geometry=HERE / "hair.geom", fragment=frag,
                   defines=defines, include_dirs=[RENDER_DIR])


def subdivisions(settings, points_per_strand: int) -> int:
    """Tessellated segments per guide segment so that a strand has at least ``settings.segments``."""
    return int(min(MAX_ISOLINES, max(1, math.ceil(settings.segments / max(1, points_per_strand - 1)))))


def draw_hair(renderer, prog, view: View) -> None:
    """One draw of every guide's patches (instanced by 64 isolines)."""
    s = renderer.settings
    st = renderer.strands
    ctx = renderer.ctx
    N = st.points_per_strand
    set_view(prog, view)
    for name, value in (("u_n", N), ("u_num_guides", st.num_guides),
                        ("u_strands_per_guide", int(s.strands_per_guide)),
                        ("u_subdivisions", subdivisions(s, N)), ("u_keep_guide", int(s.keep_guide))):
        set_uniform(prog, name, int(value))
    for name, value in (("u_clump_radius", s.clump_radius), ("u_clump_root", s.clump_root),
                        ("u_clump_tip", s.clump_tip), ("u_stray_fraction", s.stray_fraction),
                        ("u_stray_amount", s.stray_amount), ("u_width", s.width),
                        ("u_width_tip", s.width_tip)):
        set_uniform(prog, name, float(value))
    st.bind()
    vao = renderer.empty_vao(prog)
    ctx.patch_vertices = 4
    instances = math.ceil(int(s.strands_per_guide) / MAX_ISOLINES)
    vao.render(moderngl.PATCHES, vertices=st.num_segments * 4, instances=instances)


def bind_lighting(renderer, prog, frame: Frame) -> None:
    """Lights, ambient and light 0's shadow maps (texture units 1..3)."""
    lights = frame.lights[:3]
    center = renderer.scene_center()
    vecs, rads = [], []
    for light in lights:
        if light.is_point:
            vecs.append((*light.vector, 1.0))
        else:
            d = np.asarray(light.vector, float)
            d = d / np.linalg.norm(d)
            vecs.append((*d, 0.0))
        rads.append(tuple(float(c) * float(light.intensity) for c in light.color))
    while len(vecs) < 3:
        vecs.append((0.0, 1.0, 0.0, 0.0))
        rads.append((0.0, 0.0, 0.0))
    set_uniform(prog, "u_num_lights", len(lights))
    set_uniform(prog, "u_light_vec", vecs)
    set_uniform(prog, "u_light_radiance", rads)
    a = float(renderer.settings.ambient)
    set_uniform(prog, "u_ambient", (a, a, a))
    lv = frame.light_view
    if lv is not None:
        set_uniform(prog, "u_light_view_proj", lv.view_proj)
        set_uniform(prog, "u_light_eye", tuple(float(x) for x in lv.eye))
        set_uniform(prog, "u_light_dir", tuple(float(x) for x in lv.forward))
        s = renderer.settings
        texel = lv.pixel_size if lv.ortho else lv.pixel_size * float(np.linalg.norm(center - lv.eye))
        set_uniform(prog, "u_shadow_bias", float(s.shadow_bias) * texel)
        set_uniform(prog, "u_shadow_density", float(s.shadow_density))
        set_uniform(prog, "u_pcf", int(s.pcf))
        lo, hi = frame.hair_depth_range
        ext = max(hi - lo, 1e-4)
        set_uniform(prog, "u_dom_layers", tuple(float(f) * ext for f in s.dom_layers))
    t = frame.targets
    if "shadow_map" in t:
        t["shadow_map"].use(1)
        set_uniform(prog, "u_shadow_map", 1)
    if "dom" in t:
        t["dom"].use(2)
        set_uniform(prog, "u_dom", 2)


class Pass:
    """A step of the frame. ``reads``/``writes`` name the frame targets (documentation and checks)."""

    name = "pass"
    reads: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()

    def __init__(self, renderer):
        self.renderer = renderer
        self.ctx = renderer.ctx

    def enabled(self, frame: Frame) -> bool:
        return True

    def run(self, frame: Frame) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def release(self) -> None:
        pass
