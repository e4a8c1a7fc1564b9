"""Dear ImGui widgets generated from the settings dataclasses: no second list of parameters.

``widget_for(cls, field, value)`` decides, from the field's metadata, its current value and
its name, which widget edits it:

    bool                          -> checkbox
    int / float                   -> slider (when a range is known) or drag
    str with a known set          -> combo  (metadata "choices", else a module constant such as
                                             SHADOWS for ``shadows`` or KINDS for ``kind``)
    other str                     -> text input (applied on Enter)
    3 numbers                     -> colour picker (colour-like names) or drag3
    2 ints                        -> drag2
    a dataclass                   -> a tree node, edited recursively
    None or a 3-tuple (optional)  -> "default" checkbox + colour picker
    dict of numbers               -> one widget per entry

Ranges: a declared setting (``mane.setting``: RenderSettings, SimSettings and their groups)
gives its own range (or its ``slider`` inside a wide one), choices and help, and a field declared
``panel=False`` is left out (``hidden``); for other dataclasses ``field(metadata={"range": (lo,
hi)})`` or ``{"choices": (...)}`` win, ``HINTS`` gives sensible ones for a few names, fractions
(stiffness, opacity, ...) get 0..1 sliders and other numbers a drag scaled to their value. A frozen dataclass is updated with ``dataclasses.replace``; the class's own
validation decides, and its error message is shown instead of applying the change.
"""
from __future__ import annotations

import ast
import dataclasses
import functools
import importlib
import inspect
import sys
import textwrap
from dataclasses import dataclass

import numpy as np

from ..errors import ManeError

# name -> widget options for fields of dataclasses that do not declare their settings (mane.setting):
# the shading model's and the lights'. Declared settings (RenderSettings, SimSettings, WindSettings,
# SolverTuning) take their ranges and choices from their own declarations, nothing here.
HINTS: dict[str, dict] = {
    "lut_size": {"choices": (64, 128, 256, 512)},
    "dual_size": {"choices": (16, 32, 64, 128)},
    "eta": {"range": (1.01, 2.5)},
    "roughness": {"range": (0.01, 0.6)},
    "shift": {"range": (-0.3, 0.3)},
    "melanin": {"range": (0.0, 8.0)},
    "intensity": {"range": (0.0, 10.0)},
}

# where the choices of an undeclared string field live when the field's own module does not name them
CHOICE_SOURCES: dict[str, tuple[str, str]] = {
    "model": ("mane.render.shading", "MODELS"),
    "multiple_scattering": ("mane.render.shading", "MULTIPLE_SCATTERING"),
}

FRACTION_WORDS = ("stiffness", "fraction", "percent", "ratio", "friction", "opacity", "_range",
                  "dftl_damping", "clump_root", "clump_tip", "width_tip", "density_front", "density_back",
                  "probability")
COLOR_WORDS = ("color", "colour", "background", "albedo", "skin")


@dataclass(frozen=True)
class Widget:
    kind: str          # checkbox slider_int drag_int slider_float drag_float combo color drag3 drag2i
                       # optional_color dataclass dict input_text text (shown, not edited)
    lo: float = 0.0
    hi: float = 0.0
    speed: float = 1.0
    choices: tuple = ()
    format: str = "%.3f"


# ---------------------------------------------------------------------------- docs and choices
@functools.lru_cache(maxsize=None)
def field_docs(cls) -> dict[str, str]:
    """name -> the doc string under each field of a dataclass ("" when it has none)."""
    docs: dict[str, str] = {}
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        body = tree.body[0].body
        for a, b in zip(body, body[1:]):
            if (isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name) and isinstance(b, ast.Expr)
                    and isinstance(getattr(b, "value", None), ast.Constant) and isinstance(b.value.value, str)):
                docs[a.target.id] = " ".join(b.value.value.split())
    except (OSError, TypeError, SyntaxError, IndexError):
        pass
    return {f.name: f.metadata.get("help") or docs.get(f.name, "") for f in dataclasses.fields(cls)}


def hidden(cls) -> dict[str, str]:
    """name -> why, for the fields a settings class declares ``panel=False``."""
    return {f.name: f.metadata["reason"] for f in dataclasses.fields(cls)
            if "kind" in f.metadata and not f.metadata["panel"]}


def _constant(module, name):
    value = getattr(module, name, None)
    if isinstance(value, dict):
        value = tuple(value)
    if isinstance(value, (tuple, list)) and value and all(isinstance(v, (str, int)) for v in value):
        return tuple(value)
    return None


def _singular(word: str) -> str:
    return word[:-1] if word.endswith("S") and len(word) > 3 else word


def choices_for(cls, name: str, value=None) -> tuple:
    """The allowed values of a field: metadata, then ``HINTS``, then a module constant named
    after the field (SHADOWS for shadows, INTERPOLATIONS, GEOMETRIES, KINDS for kind, ...)."""
    f = {x.name: x for x in dataclasses.fields(cls)}.get(name)
    if f is not None and "kind" in f.metadata:      # a declared setting: its own choices or none
        return tuple(f.metadata["choices"] or ())
    if f is not None and "choices" in f.metadata:
        return tuple(f.metadata["choices"])
    if "choices" in HINTS.get(name, {}):
        return tuple(HINTS[name]["choices"])
    if not isinstance(value, str):
        return ()
    module = sys.modules.get(cls.__module__)
    up = name.upper()
    candidates = [up + "S", up + "ES", up, up[:-1] + "IES" if up.endswith("Y") else None]
    for cand in filter(None, candidates):
        found = _constant(module, cand) if module is not None else None
        if found and value in found:
            return found
    # a constant that shares a word with the field and holds its value: OIT_METHODS for oit,
    # KBUFFER_MODES for oit_kbuffer, INTERPOLATION_MODES for interpolation_mode
    words = {_singular(w) for w in up.split("_")}
    best, best_score = None, 0
    for const in dir(module) if module is not None else ():
        if not const.isupper():
            continue
        found = _constant(module, const)
        if not found or value not in found:
            continue
        score = len(words & {_singular(w) for w in const.split("_")})
        if score > best_score:
            best, best_score = found, score
    if best is not None:
        return best
    if name in CHOICE_SOURCES:
        mod_name, const = CHOICE_SOURCES[name]
        try:
            found = _constant(importlib.import_module(mod_name), const)
        except Exception:
            found = None
        if found:
            extra = (value, "auto") if name == "multiple_scattering" else (value,)
            return tuple(dict.fromkeys(tuple(found) + extra))
    return ()


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def widget_for(cls, f: dataclasses.Field, value) -> Widget:
    """Which widget edits field ``f`` holding ``value`` (see the module doc)."""
    name = f.name
    meta = dict(HINTS.get(name, {})) if "kind" not in f.metadata else {}
    meta.update(f.metadata or {})
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return Widget("dataclass")
    if isinstance(value, bool):
        return Widget("checkbox")
    choices = choices_for(cls, name, value)
    if choices and (isinstance(value, str) or (_is_number(value) and value in choices)):
        return Widget("combo", choices=choices)
    if isinstance(value, str):
        return Widget("input_text")    # free text, applied on Enter; the class validates it
    if _is_number(value):
        is_int = isinstance(value, (int, np.integer))
        if "range" in meta:
            lo, hi = meta["range"]
            return Widget("slider_int" if is_int else "slider_float", lo, hi, format=meta.get("format", "%.3f"))
        if "kind" in meta:     # a declared setting without both ends: a drag within the end it has
            lo = meta["lo"] if meta["lo"] is not None else -1e9
            hi = meta["hi"] if meta["hi"] is not None else (0 if is_int else 1e9)
            if is_int:
                return Widget("drag_int", lo, hi, speed=max(0.05, abs(int(value)) * 0.01))
            return Widget("drag_float", lo, hi, speed=max(abs(float(value)), 1e-3) * 0.01,
                          format="%.5f" if 0 < abs(float(value)) < 0.01 else "%.4f")
        if not is_int and 0.0 <= float(value) <= 1.0 and any(w in name for w in FRACTION_WORDS):
            return Widget("slider_float", 0.0, 1.0)
        if is_int:
            lo = 1 if value >= 1 else 0
            return Widget("drag_int", lo, 0, speed=max(0.05, abs(int(value)) * 0.01))
        lo = 0.0 if value >= 0 else -1e9
        return Widget("drag_float", lo, 1e9, speed=max(abs(float(value)), 1e-3) * 0.01,
                      format="%.5f" if 0 < abs(float(value)) < 0.01 else "%.4f")
    if value is None and any(w in name for w in COLOR_WORDS):
        return Widget("optional_color")
    if isinstance(value, (tuple, list)) and len(value) == 3 and all(_is_number(v) for v in value):
        if any(w in name for w in COLOR_WORDS):
            return Widget("color")
        scale = max(max(abs(float(v)) for v in value), 1e-3)
        return Widget("drag3", speed=scale * 0.01)
    if isinstance(value, (tuple, list)) and len(value) == 2 and all(isinstance(v, (int, np.integer)) for v in value):
        return Widget("drag2i", 8, 8192, speed=1.0)
    if isinstance(value, dict):
        return Widget("dict")
    return Widget("text")   # shown, not edited (tuples of tuples, objects)


def widget_plan(obj, exclude=()) -> dict[str, Widget]:
    """field name -> Widget for every field of the dataclass instance ``obj`` that the panel shows
    (not those declared ``panel=False``, nor ``exclude``): for tests and docs."""
    cls = type(obj)
    skip = set(exclude) | set(hidden(cls))
    return {f.name: widget_for(cls, f, getattr(obj, f.name)) for f in dataclasses.fields(cls) if f.name not in skip}


def _label(name: str) -> str:
    return name.replace("_", " ")


# ---------------------------------------------------------------------------- the editor
class SettingsEditor:
    """Draws dataclass editors; ``error`` holds the last refused change's message."""

    def __init__(self, expand: bool = False):
        self.error: str | None = None
        self.edits = 0
        self.expand = expand     # open every tree node (screenshots, tests)

    def _open(self) -> None:
        if self.expand:
            from imgui_bundle import imgui

            imgui.set_next_item_open(True, imgui.Cond_.always)

    def _replace(self, obj, **changes):
        try:
            new = dataclasses.replace(obj, **changes)
        except (ManeError, ValueError, TypeError) as exc:
            self.error = f"{type(obj).__name__}.{', '.join(changes)}: {exc}"
            return obj, False
        self.error = None
        self.edits += 1
        return new, True

    def edit(self, obj, *, exclude=(), only=None, id: str | None = None):
        """Widgets for every field of the dataclass ``obj`` (or those named in ``only`` that it
        has); returns (changed, new object)."""
        from imgui_bundle import imgui

        cls = type(obj)
        docs = field_docs(cls)
        changed_any = False
        imgui.push_id(id or cls.__name__)
        all_fields = {f.name: f for f in dataclasses.fields(cls)}
        order = list(all_fields) if only is None else [n for n in only if n in all_fields]
        skip = set(exclude) | set(hidden(cls))
        for f in (all_fields[n] for n in order):
            if f.name in skip:
                continue
            value = getattr(obj, f.name)
            w = widget_for(cls, f, value)
            changed, new_value = self._widget(f.name, w, value, docs.get(f.name, ""))
            if changed:
                if dataclasses.is_dataclass(obj) and getattr(cls, "__dataclass_params__").frozen:
                    obj, ok = self._replace(obj, **{f.name: new_value})
                else:
                    try:
                        setattr(obj, f.name, new_value)
                        if hasattr(obj, "__post_init__"):
                            obj.__post_init__()
                        ok = True
                    except (ManeError, ValueError, TypeError) as exc:
                        setattr(obj, f.name, value)
                        self.error = f"{cls.__name__}.{f.name}: {exc}"
                        ok = False
                changed_any = changed_any or ok
        imgui.pop_id()
        return changed_any, obj

    def _widget(self, name: str, w: Widget, value, doc: str):
        from imgui_bundle import imgui

        label = _label(name)
        changed, new = False, value
        if w.kind == "dataclass":
            self._open()
            if imgui.tree_node(label):
                changed, new = self.edit(value, id=name)
                imgui.tree_pop()
            return changed, new
        if w.kind == "checkbox":
            changed, new = imgui.checkbox(label, bool(value))
        elif w.kind == "combo":
            items = [str(c) for c in w.choices]
            idx = w.choices.index(value) if value in w.choices else 0
            changed, idx = imgui.combo(label, idx, items)
            new = w.choices[idx]
        elif w.kind == "slider_int":
            changed, new = imgui.slider_int(label, int(value), int(w.lo), int(w.hi))
        elif w.kind == "drag_int":
            changed, new = imgui.drag_int(label, int(value), w.speed, int(w.lo), int(w.hi))
        elif w.kind == "slider_float":
            changed, new = imgui.slider_float(label, float(value), float(w.lo), float(w.hi), w.format)
        elif w.kind == "drag_float":
            changed, new = imgui.drag_float(label, float(value), w.speed, float(w.lo), float(w.hi), w.format)
        elif w.kind == "color":
            changed, col = imgui.color_edit3(label, [float(x) for x in value])
            new = tuple(float(x) for x in col)
        elif w.kind == "optional_color":
            on = value is not None
            c1, on = imgui.checkbox(f"{label}##set", on)
            if on:
                imgui.same_line()
                c2, col = imgui.color_edit3(f"##{name}", [0.1, 0.05, 0.025] if value is None else [float(x) for x in value])
                changed, new = c1 or c2, tuple(float(x) for x in col)
            else:
                changed, new = c1, None
        elif w.kind == "drag3":
            changed, v = imgui.drag_float3(label, [float(x) for x in value], w.speed)
            new = tuple(float(x) for x in v)
        elif w.kind == "drag2i":
            changed, v = imgui.drag_int2(label, [int(x) for x in value], w.speed, int(w.lo), int(w.hi))
            new = tuple(int(x) for x in v)
        elif w.kind == "input_text":
            changed, new = imgui.input_text(label, str(value), imgui.InputTextFlags_.enter_returns_true)
        elif w.kind == "dict":
            self._open()
            if imgui.tree_node(label):
                changed, new = self._edit_dict(name, value)
                imgui.tree_pop()
        else:
            imgui.text(f"{label}: {value!r}"[:120])
        if doc:
            imgui.set_item_tooltip(doc)
        return changed, new

    def _edit_dict(self, name: str, d: dict):
        from imgui_bundle import imgui

        changed, out = False, dict(d)
        imgui.push_id(name)
        for key, value in d.items():
            c, v = self._widget(str(key), _dict_widget(str(key), value), value, "")
            if c:
                out[key] = v
                changed = True
        imgui.pop_id()
        return changed, out


def _dict_widget(key: str, value) -> Widget:
    meta = HINTS.get(key, {})
    if isinstance(value, bool):
        return Widget("checkbox")
    if _is_number(value):
        if "range" in meta:
            return Widget("slider_float", *meta["range"])
        if 0.0 <= float(value) <= 1.0 and any(w in key for w in FRACTION_WORDS + ("specular",)):
            return Widget("slider_float", 0.0, 1.0)
        return Widget("drag_float", 0.0, 1e9, speed=max(abs(float(value)), 1e-3) * 0.01)
    if isinstance(value, (tuple, list)) and len(value) == 3 and all(_is_number(v) for v in value):
        return Widget("color" if any(w in key for w in COLOR_WORDS) else "drag3",
                      speed=max(max(abs(float(v)) for v in value), 1e-3) * 0.01)
    if isinstance(value, (tuple, list)) and len(value) == 2 and all(_is_number(v) for v in value):
        return Widget("text")
    return Widget("text")


# ---------------------------------------------------------------------------- the viewer's panel
QUICK_RENDER_FIELDS = ("shading", "shadows", "oit", "interpolation_mode", "strands_per_guide",
                       "segments", "draw_head")


def draw_panel(v) -> None:
    """The viewer's window of controls (``v``: a mane.viewer.Viewer)."""
    from imgui_bundle import imgui

    from .choices import PANEL_WIDTH

    if v.editor is None:
        v.editor = SettingsEditor()
    v.editor.expand = bool(getattr(v, "expand_panel", False))
    ed = v.editor
    w, h = v.wnd.size
    imgui.set_next_window_pos(imgui.ImVec2(8, 8), imgui.Cond_.first_use_ever)
    imgui.set_next_window_size(imgui.ImVec2(min(PANEL_WIDTH, w - 16), h - 16), imgui.Cond_.first_use_ever)
    imgui.begin("mane")
    try:
        last = v.frame_ms_history[-1] if v.frame_ms_history else 0.0
        imgui.text(f"{v.fps:5.1f} fps ({last:.1f} ms)  {v.renderer.rendered_strands:,} strands")
        still, n = v.renderer.still_frames, int(v.renderer.settings.accumulate)
        if n > 1:   # a paused, still view sharpens (RenderSettings.accumulate)
            imgui.text(f"still picture: {still} of {n} frames averaged" if still else "moving: one frame a picture")
        if v.error:
            imgui.push_text_wrap_pos(0.0)
            imgui.text_colored(imgui.ImVec4(1.0, 0.35, 0.3, 1.0), f"error: {v.error}")
            imgui.pop_text_wrap_pos()
            if imgui.small_button("dismiss"):
                v.error = None
        if v.status:
            imgui.text_wrapped(v.status)
        _simulation(v, ed, imgui)
        _sphere(v, imgui)
        _lights(v, ed, imgui)
        _hair_colour(v, imgui)
        _rendering(v, ed, imgui)
        _performance(v, imgui)
        _capture(v, imgui)
    finally:
        imgui.end()
    if ed.error:
        v.error, ed.error = ed.error, None


def ed_open(v) -> None:
    if v.editor is not None:
        v.editor._open()


def _slider(cls, name: str) -> tuple[float, float]:
    """A declared setting's slider range (its ``slider``, else its range)."""
    lo, hi = next(f for f in dataclasses.fields(cls) if f.name == name).metadata["range"]
    return float(lo), float(hi)


def _simulation(v, ed, imgui) -> None:
    from ..presets import STYLE_PRESETS
    from ..sim import WindSettings
    from .choices import MOTIONS

    ed_open(v)
    if not imgui.collapsing_header("Simulation", imgui.TreeNodeFlags_.default_open):
        return
    if imgui.button("pause" if v.playing else "play"):
        v.playing = not v.playing
    imgui.same_line()
    if imgui.button("step"):
        v.playing = False
        v.step_once()
    imgui.same_line()
    if imgui.button("reset"):
        v.reset()
    imgui.same_line()
    imgui.text(f"t = {v.sim_time:6.2f} s")
    changed, i = imgui.combo("head motion", MOTIONS.index(v.motion), list(MOTIONS))
    if changed:
        v.set_motion(MOTIONS[i])
    _, v.time_scale = imgui.slider_float("time scale", v.time_scale, 0.0, 2.0)
    names = list(STYLE_PRESETS)
    changed, i = imgui.combo("style preset", names.index(v.style) if v.style in names else 0, names)
    if changed:
        v.apply_style(names[i])
    imgui.separator_text("wind")
    c0, on = imgui.checkbox("wind on", v.wind_on)
    c1, v.wind_azimuth = imgui.slider_float("direction (deg)", v.wind_azimuth, 0.0, 360.0)
    imgui.set_item_tooltip("where the wind blows to, about the vertical: 0 toward +Z (the way the face looks), "
                           "90 toward +X")
    c2, v.wind_elevation = imgui.slider_float("elevation (deg)", v.wind_elevation, -60.0, 60.0)
    c3, v.wind_strength = imgui.slider_float("strength (m/s)", v.wind_strength, 0.0, 10.0)
    c4, v.wind_gust = imgui.slider_float("gustiness", v.wind_gust, *_slider(WindSettings, "gust"))
    c5, v.wind_turbulence = imgui.slider_float("turbulence (m/s)", v.wind_turbulence,
                                               *_slider(WindSettings, "turbulence"))
    if c0 or c1 or c2 or c3 or c4 or c5:
        v.set_wind(on)
    ed_open(v)
    if imgui.tree_node("all simulation settings"):
        changed, new = ed.edit(v.sim.settings)
        if changed:
            v.sim.settings = new
        imgui.tree_pop()


def _sphere(v, imgui) -> None:
    ed_open(v)
    if v.sphere is None or not imgui.collapsing_header("Collision sphere"):
        return
    imgui.text_wrapped("drag it with the left mouse button; W/A/S/D/Q/E move it")
    _, v.show_sphere = imgui.checkbox("show and collide", v.show_sphere)
    _, v.sweep = imgui.checkbox("sweep through the hair", v.sweep)
    s = v.sphere
    c, r = imgui.slider_float("radius (m)", float(s.radius), 0.005, max(0.5, float(s.radius) * 2))
    if c and r > 0:
        s.radius = float(r)
    c, f = imgui.slider_float("friction", float(s.friction), 0.0, 1.0)
    if c:
        s.friction = float(f)
    c, p = imgui.drag_float3("centre (m)", [float(x) for x in s.transform[:3, 3]], 0.002)
    if c:
        v.move_sphere(p)


def _lights(v, ed, imgui) -> None:
    from ..render.lights import MAX_LIGHTS, Light

    ed_open(v)
    if not imgui.collapsing_header("Lights"):
        return
    imgui.text_wrapped("drag a light's handle (the ball in its colour) to move or turn it; "
                       "ctrl + left drag turns the selected light")
    _, v.show_light_handles = imgui.checkbox("show handles", v.show_light_handles)
    remove = None
    for i, light in enumerate(list(v.lights)):
        imgui.push_id(f"light{i}")
        if imgui.radio_button(f"light {i}", v.selected_light == i):
            v.selected_light = i
        imgui.same_line()
        _, v.casts[i] = imgui.checkbox("casts shadows", v.casts[i])
        if len(v.lights) > 1:
            imgui.same_line()
            if imgui.small_button("remove"):
                remove = i
        changed, new = ed.edit(light, id=f"light{i}")
        if changed:
            v.lights[i] = new
        imgui.pop_id()
    if remove is not None:
        del v.lights[remove]
        del v.casts[remove]
        v.selected_light = min(v.selected_light, len(v.lights) - 1)
    if len(v.lights) < MAX_LIGHTS and imgui.button("add light"):
        v.lights.append(Light("directional", (0.0, 1.0, 0.2), (1.0, 1.0, 1.0), 1.0))
        v.casts.append(True)


def _hair_colour(v, imgui) -> None:
    ed_open(v)
    if not imgui.collapsing_header("Hair colour"):
        return
    if imgui.radio_button("RGB", v.color_mode == "rgb"):
        v.color_mode = "rgb"
    imgui.same_line()
    if imgui.radio_button("melanin", v.color_mode == "melanin"):
        v.color_mode = "melanin"
    if v.color_mode == "rgb":
        col = v.render_settings.hair_color or (0.1, 0.05, 0.025)
        changed, col = imgui.color_edit3("colour (linear)", [float(x) for x in col])
        if changed:
            v.render_settings = dataclasses.replace(v.render_settings, hair_color=tuple(float(x) for x in col))
    else:
        from ..render.shading import PRESETS

        names = list(PRESETS)
        current = next((k for k, m in PRESETS.items() if tuple(m) == tuple(v.melanin)), None)
        labels = names + ["custom"]
        changed, i = imgui.combo("preset", labels.index(current) if current else len(names), labels)
        if changed and i < len(names):
            v.melanin = PRESETS[names[i]]
        _, e = imgui.slider_float("eumelanin", float(v.melanin[0]), 0.0, 8.0)
        _, p = imgui.slider_float("pheomelanin", float(v.melanin[1]), 0.0, 8.0)
        imgui.set_item_tooltip("Chiang et al. 2016 concentrations: black ~8, brown ~1.3, blond ~0.3, red: pheomelanin")
        v.melanin = (e, p)


def _rendering(v, ed, imgui) -> None:
    from .choices import AA_CHOICES

    ed_open(v)
    if not imgui.collapsing_header("Rendering", imgui.TreeNodeFlags_.default_open):
        return
    changed, new = ed.edit(v.render_settings, only=QUICK_RENDER_FIELDS, id="quick")
    if changed:
        v.render_settings = new
    current = v.aa_name()
    changed, i = imgui.combo("anti-aliasing", AA_CHOICES.index(current) if current in AA_CHOICES else 0,
                             list(AA_CHOICES))
    if changed:
        v.set_aa(AA_CHOICES[i])
    ed_open(v)
    if imgui.tree_node("all render settings"):
        # the fields declared panel=False (size, shadow_lights) are left out by the editor itself
        changed, new = ed.edit(v.render_settings, exclude=QUICK_RENDER_FIELDS, id="all")
        if changed:
            v.render_settings = new
        imgui.tree_pop()


def _performance(v, imgui) -> None:
    ed_open(v)
    if not imgui.collapsing_header("Performance", imgui.TreeNodeFlags_.default_open):
        return
    if v.frame_ms_history:
        arr = np.asarray(v.frame_ms_history, np.float32)
        imgui.plot_lines("##frame", arr, overlay_text=f"frame {arr[-1]:.1f} ms, {v.fps:.1f} fps",
                         scale_min=0.0, scale_max=float(max(arr.max(), 1.0)),
                         graph_size=imgui.ImVec2(-1, 48))
    _, v.auto_quality = imgui.checkbox(f"keep {v.target_fps:g} fps (scale down)", v.auto_quality)
    imgui.set_item_tooltip("below the target frame rate, take fewer strands, then a 1-texel shadow filter, "
                           "then no shadows, then one strand per guide")
    if v.auto_quality:
        measured = f" at {v.auto_quality_fps:.1f} fps" if v.auto_quality_fps else ""
        imgui.same_line()
        imgui.text(f"{v.auto_quality_state}{measured}")
    source = v.renderer.profiler.source
    imgui.text(f"GPU ms per pass ({'CPU-timed: software renderer' if source == 'cpu' else source})")
    hist = {k: s for k, s in v.pass_history.items() if s}
    total = sum(float(np.mean(s[-10:])) for s in hist.values()) or 1e-3
    for name, s in hist.items():    # a live plot per pass, each on its own scale
        arr = np.asarray(s, np.float32)
        ms = float(np.mean(arr[-10:]))
        imgui.plot_lines(f"##{name}", arr, overlay_text=f"{name} {ms:.2f} ms ({100 * ms / total:.0f}%)",
                         scale_min=0.0, scale_max=float(max(arr.max(), 1e-3)) * 1.1,
                         graph_size=imgui.ImVec2(-1, 26))
        imgui.set_item_tooltip(f"{name}: the last {len(arr)} frames, 0 to {arr.max():.2f} ms")


def _capture(v, imgui) -> None:
    ed_open(v)
    if not imgui.collapsing_header("Capture and files", imgui.TreeNodeFlags_.default_open):
        return
    if imgui.button("screenshot (F12)"):
        v.screenshot()
    imgui.same_line()
    if imgui.button("stop recording (F9)" if v.recorder is not None else "record MP4 (F9)"):
        v.toggle_recording()
    if v.recorder is not None:
        imgui.text_colored(imgui.ImVec4(1.0, 0.3, 0.3, 1.0), f"REC {v.recorder.path} ({v.recorder.frames} frames)")
    if v.last_recording is not None:
        imgui.text_wrapped(f"video: {v.last_recording}")
    if v.last_screenshot is not None:
        imgui.text_wrapped(f"screenshot: {v.last_screenshot}")
    imgui.text_wrapped("drop a hair file or a head mesh on the window to load it")
    _, v._path_text = imgui.input_text("##path", getattr(v, "_path_text", ""))
    imgui.same_line()
    if imgui.button("load"):
        v.load_file(v._path_text.strip())
