"""The interactive viewer: a moderngl-window (GLFW) window, a Simulator and a Renderer on its
OpenGL context, and a Dear ImGui panel generated from the settings dataclasses.

    from mane.viewer import Viewer
    v = Viewer(groom, head)        # opens the window (needs a display: X11 or Xvfb)
    v.run()                        # until the window closes
    # or drive it: v.frame(); v.key_event(...); v.mouse_drag_event(...); v.read_window()

Mouse: left drag orbits (or drags the collision sphere or a light's handle when it starts on
one), right or middle drag (or shift + left) pans, the wheel zooms, ctrl + left drag turns the
selected light. Each light has a handle, a small ball in its colour: a point light's sits at its
position and moves on the plane facing the camera; a directional light's sits on a sphere about
the groom's centre, toward the light, and dragging it over that sphere turns the light.
Keys: W/A/S/D/Q/E move the sphere, space play / pause, N single step, R reset, F frame the
scene, H hide the panel, M next head motion, F12 screenshot, F9 record on / off, Esc quit.
Drop a hair file (any format ``mane.load`` reads) or a mesh on the window to load it.
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from ..errors import GPUError, ManeError, UsageError
from ..presets import SOFTWARE_LADDER, STYLE_PRESETS, TARGET_FPS, demo_scene, demo_sim_settings, quality_named
from ..render.gizmos import GizmoPass, handle_color  # noqa: F401  (GizmoPass, handle_color: re-exported)
from ..render.present import Presenter
from .camera_control import OrbitControl
from .choices import AA_CHOICES, MOTIONS, PANEL_WIDTH
from .picking import PlaneDrag, SphereDrag, in_front, keyboard_offset, pixel_ray, project, ray_sphere

SWEEP_PERIOD = 4.0   # seconds per turn of the demo's sphere
HANDLE_PIXELS = 7.0  # a light handle's radius on screen
PICK_PIXELS = 12.0   # how near the cursor must be to a light handle's centre to grab it
STEP_UP = 1.6        # the auto-scaler takes a step back at this many times its target frame rate
SETTLE_MARGIN = 1.1  # ... and settles this far above it: the rate wanders by a few per cent as the hair,
                     # the sphere and the head move and the panel changes

def display_available() -> bool:
    """True when an X11 or Wayland display is named and GLFW can initialise on it."""
    import os

    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    try:
        import glfw
    except Exception:
        return False
    reporting = getattr(glfw, "ERROR_REPORTING", "warn")
    try:
        glfw.ERROR_REPORTING = False    # no warning for a display that is named but not there
        ok = bool(glfw.init())
    except Exception:
        return False
    finally:
        glfw.ERROR_REPORTING = reporting
    return ok


_egl = None


def release_egl_current() -> None:
    """Make no EGL context current on this thread (a headless mane context may be): with Mesa,
    glXMakeCurrent fails with BadAccess, and Xlib exits the process, while one is."""
    global _egl
    import ctypes

    if _egl is None:
        try:
            _egl = ctypes.CDLL("libEGL.so.1")
        except OSError:
            _egl = False
            return
        _egl.eglGetCurrentContext.restype = ctypes.c_void_p
        _egl.eglGetCurrentDisplay.restype = ctypes.c_void_p
        _egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
        _egl.eglMakeCurrent.restype = ctypes.c_uint
    if not _egl:
        return
    if _egl.eglGetCurrentContext():
        _egl.eglMakeCurrent(_egl.eglGetCurrentDisplay(), None, None, None)


def create_window(size=(960, 540), title: str = "mane", visible: bool = True, vsync: bool = False):
    """A moderngl-window GLFW window with an OpenGL 4.3 core context (ManeError when none can be made)."""
    if not display_available():
        raise GPUError("no display to open a window on: set DISPLAY (X11) or WAYLAND_DISPLAY, or start "
                       "Xvfb (Xvfb :99 & export DISPLAY=:99); `mane demo` renders headless without one")
    try:
        from moderngl_window.context.glfw import Window
    except ImportError as exc:
        raise GPUError(f"the viewer needs moderngl-window and glfw ({exc}); pip install 'mane'") from None
    release_egl_current()
    try:
        wnd = Window(title=title, size=tuple(int(s) for s in size), gl_version=(4, 3), vsync=vsync,
                     resizable=True, visible=visible, samples=0)
    except Exception as exc:
        raise GPUError(f"cannot open a window with OpenGL 4.3 core: {exc}") from None
    return wnd


class Viewer:
    """The ``mane view`` window (see the module doc). ``window``: a moderngl-window window to
    use (default: a new GLFW one of ``size``)."""

    def __init__(self, groom=None, head=None, *, window=None, size=(960, 540), quality: str = "auto",
                 demo: bool = False, motion: str | None = None, out_dir="out/viewer", title: str = "mane view",
                 visible: bool = True, max_guides: int | None = None, auto_quality: bool | None = None,
                 target_fps: float | None = None):
        from imgui_bundle import imgui
        from moderngl_window.integrations.imgui_bundle import ModernglWindowRenderer

        from ..gpu import is_software_renderer, renderer_name

        self.wnd = window if window is not None else create_window(size, title, visible)
        self.ctx = self.wnd.ctx
        self._make_current()
        if self.ctx.version_code < 430:
            raise GPUError(f"the window's OpenGL {self.ctx.version_code} is below 4.3")
        self.software = is_software_renderer(self.ctx)
        self.gl_name = renderer_name(self.ctx)
        self.out_dir = Path(out_dir)
        self.demo = bool(demo)
        self.quality = self._quality(quality)

        # on a software renderer: step down SOFTWARE_LADDER while the frame rate is below target
        self.auto_quality = self.software if auto_quality is None else bool(auto_quality)
        self.target_fps = float(target_fps) if target_fps is not None else TARGET_FPS
        self.quality_steps: list[str] = []
        self.auto_quality_state = "measuring" if self.auto_quality else "off"
        """the auto-scaler: "off", "measuring" (first check pending), "scaling" (a step was
        just taken), "settled" (at the target or above), "floor" (the last step taken)."""
        self.auto_quality_fps: float | None = None   # the frame rate its last check measured
        self._ladder = 0
        self._undo: list[dict] = []                  # per step taken: the fields it changed, as they were
        self._ladder_failures: dict[int, int] = {}   # ladder level -> times it fell below the target
        self._fast_checks = self._slow_checks = 0
        self.max_guides = max_guides if max_guides is not None else (self.quality.guides * 2 if self.software else 200000)

        # ImGui on the window's context
        self._imgui_ctx = imgui.create_context()
        imgui.get_io().set_ini_filename("")
        self.imgui = ModernglWindowRenderer(self.wnd)
        self.editor = None
        self.show_panel = True
        self.panel_drawn = False
        self._presenter = Presenter(self.ctx)

        # state
        self.error: str | None = None
        self.status: str = ""
        self.playing = True
        self.sim_time = 0.0
        self.time_scale = 1.0
        self.motion = motion if motion is not None else ("nod" if demo else "none")
        if self.motion not in MOTIONS:
            raise UsageError(f"head motion must be one of {', '.join(MOTIONS)}; got {self.motion!r}")
        self.sweep = bool(demo)
        self.show_sphere = True
        self.sphere = None
        self.orbit: OrbitControl | None = None
        self.sim = None
        self.renderer = None
        self.groom = None
        self.head = None
        self.head_collider = None
        self.lights = []
        self.casts = []
        self.selected_light = 0
        self.show_light_handles = True
        self.hover_light: int | None = None
        self.dragging_light: int | None = None
        self.light_centre = np.zeros(3)     # directional lights' handles sit on a sphere about it
        self.light_distance = 0.4           # ... of this radius (m)
        self.wind_on = bool(demo)
        self.wind_azimuth, self.wind_elevation = 27.0, 0.0   # degrees; demo: from the front-left
        self.wind_strength, self.wind_gust, self.wind_turbulence = 1.34, 1.0, 0.6
        self.color_mode = "melanin"           # melanin drives the colour; RGB is an opt-in
        from ..render.shading import PRESETS

        self.melanin = PRESETS["brown"]
        self.style = next(iter(STYLE_PRESETS))
        self.frames = 0
        self.fps = 0.0
        self.frame_ms_history: list[float] = []
        self.pass_history: dict[str, list[float]] = {}
        self.last_screenshot: Path | None = None
        self.last_recording: Path | None = None
        self.recorder = None
        self._screenshot_request: Path | None | bool = False
        self._single_step = False
        self._held: set[str] = set()
        self._buttons: set[int] = set()
        self._mods = (False, False, False)
        self.dragging_sphere = False
        self.hover_sphere = False
        self._last_overlay = None   # the gizmos' state the last frame drew (_overlay_key)
        self._drag: PlaneDrag | SphereDrag | None = None
        self._drag_mode: str | None = None
        self._last = None
        self.closed = False

        self._connect_events()
        self._head_is_users = head is not None
        try:
            self.load_scene(groom, head)
        except BaseException:
            self.close()
            raise
        first = f"{self.gl_name}: quality {self.quality.name}"
        self.status = f"{first}; {self.status}" if self.status else first

    # ------------------------------------------------------------------ set-up
    def _quality(self, name: str):
        return quality_named(name, self.software)

    def _make_current(self) -> None:
        """Make the window's GL context current (another, headless one may have been since)."""
        win = getattr(self.wnd, "_window", None)
        if win is not None:
            import glfw

            release_egl_current()
            glfw.make_context_current(win)
        self._use_imgui()

    def _use_imgui(self) -> None:
        """Make this window's Dear ImGui context current (another viewer's may be)."""
        ctx = getattr(self, "_imgui_ctx", None)
        if ctx is not None:
            from imgui_bundle import imgui

            imgui.set_current_context(ctx)

    def _connect_events(self) -> None:
        w = self.wnd
        w.render_func = lambda t, dt: None
        w.resize_func = self.resize
        w.key_event_func = self.key_event
        w.mouse_position_event_func = self.mouse_position_event
        w.mouse_press_event_func = self.mouse_press_event
        w.mouse_release_event_func = self.mouse_release_event
        w.mouse_drag_event_func = self.mouse_drag_event
        w.mouse_scroll_event_func = self.mouse_scroll_event
        w.unicode_char_entered_func = self.unicode_char_entered
        w.files_dropped_event_func = self.files_dropped_event
        win = getattr(w, "_window", None)
        if win is not None:    # moderngl-window's GLFW window does not forward drops itself
            import glfw

            glfw.set_drop_callback(win, lambda _w, paths: self.files_dropped_event(0, 0, list(paths)))

    # ------------------------------------------------------------------ scene
    def load_scene(self, groom=None, head=None) -> None:
        """Simulate and draw ``groom`` (None: the default groom) on ``head`` (None: the default
        head with the default groom, no head with a given groom)."""
        from ..render.lights import default_lights
        from ..sim import MeshCollider, Simulator, Sphere

        q = self.quality
        if groom is None and head is not None:     # grow the default groom on the given head
            from ..grooming.scene import default_groom

            try:
                groom = default_groom(head, num_guides=q.guides, points=q.points).resampled(q.points)
            except (ValueError, ManeError) as exc:
                self.error = f"cannot grow hair on that head ({exc}): the default head and groom instead"
                head = None
        if groom is None:
            groom, default_head = demo_scene(q)
            head = head if head is not None else default_head
        groom = self._fit_groom(groom)
        lo, hi = groom.bbox()
        centre = (lo + hi) / 2
        size = 0.25 * float(np.max(hi - lo))
        self._sweep_centre, self._sweep_radius = centre, size
        self.light_centre, self.light_distance = centre.astype(float), 0.55 * float(np.linalg.norm(hi - lo))
        old_sphere = self.sphere
        sphere = Sphere(center=centre + size * np.array([1.6, 0.2, 0.0]), radius=size * 0.45, friction=0.3)
        if old_sphere is not None and self.groom is not None:
            sphere.friction = old_sphere.friction
        colliders = [sphere]
        head_collider = None
        if head is not None:
            head_collider = MeshCollider(head, margin=0.001)
            colliders.insert(0, head_collider)
        settings = self.sim.settings if self.sim is not None else demo_sim_settings(q, wind=self.wind_on,
                                                                                     dt=q.viewer_sim_dt)
        if not self.lights:
            self.lights = default_lights()
            self.casts = [True] * len(self.lights)   # every light casts (RenderSettings.shadow_lights)
        if self.renderer is None:
            self.render_settings = q.render_settings(size=self.render_size())
            self._warm_up(groom, head, colliders, settings)
        sim = Simulator(groom, colliders=colliders, settings=settings, ctx=self.ctx, profile=True)
        if self.sim is not None:
            self.sim.release()
        self.sim, self.sphere, self.head, self.head_collider, self.groom = sim, sphere, head, head_collider, groom
        self.sim_time = 0.0
        self._apply_motion(0.0)
        self.sim.reset()
        self._rebuild_renderer(force=True)
        # the box's framing, not the points': it leaves room around the hair for the panel and
        # the lights' handles
        self.orbit = OrbitControl.from_camera(self.renderer.default_camera(25.0, 10.0, points=None),
                                              radius=0.5 * float(np.linalg.norm(hi - lo)))
        if self.show_panel:    # the panel covers the left: centre the scene in what is left
            self.orbit.pan(min(PANEL_WIDTH, self.wnd.size[0] // 3) / 2, 0, self.wnd.size[1])
            self.orbit.home = (self.orbit.target.copy(), *self.orbit.home[1:])
        if self.wind_on:
            self.set_wind(True)

    def _warm_up(self, groom, head, colliders, sim_settings) -> None:
        """The first scene's programs compiled before its first frame (mane.warmup; the terminal's
        progress line counts them) on a GPU, where the scan-form tuner would otherwise compile a
        form in the frames it first tries it; a CPU rasteriser's first frame compiles the same."""
        from ..gpu.capabilities import get_capabilities
        from ..warmup import warm_up

        if get_capabilities(self.ctx).is_software:
            return
        warm_up(self.ctx, groom=groom, head=head, render_settings=self.effective_render_settings(),
                sim_settings=sim_settings, colliders=colliders)

    def _fit_groom(self, groom):
        n = groom.num_strands
        if n > self.max_guides:
            keep = np.unique(np.linspace(0, n - 1, self.max_guides).round().astype(np.int64))
            groom = groom.subset(keep)
            self.status = f"simulating {len(keep)} of {n} strands (every {n / len(keep):.1f}th) on {self.gl_name}"
        return groom

    def render_size(self) -> tuple[int, int]:
        w, h = self.wnd.buffer_size
        return (max(int(w), 8), max(int(h), 8))

    def effective_render_settings(self):
        """The panel's settings with the window's size and the lights' shadow casters applied."""
        s = self.render_settings
        casters = sum(1 for c in self.casts if c)
        # the auto-scaler's "key light's shadows only" lowers the settings' own shadow_lights
        changes = {"size": self.render_size(), "shadow_lights": max(1, min(casters, 4, int(s.shadow_lights)))}
        if casters == 0:
            changes["shadows"] = "none"
        if self.color_mode == "melanin":
            opts = dict(s.shading_options)
            opts["melanin"] = tuple(float(x) for x in self.melanin)
            changes.update(hair_color=None, shading_options=opts)
        else:
            opts = {k: v for k, v in s.shading_options.items() if k != "melanin"}
            if opts != s.shading_options:
                changes["shading_options"] = opts
        return dataclasses.replace(s, **changes)

    def _rebuild_renderer(self, force: bool = False) -> None:
        from ..render import Renderer

        eff = self.effective_render_settings()
        if not force and self.renderer is not None and eff == self.renderer.settings:
            return
        old = self.renderer
        try:
            r = Renderer(eff, ctx=self.ctx, profile=True)
            r.set_strands(self.sim)
            r.set_head(self.head)
            r.set_head_transform(self.sim.state.head)
            # into the frame before a still picture's mean takes it (the gizmos' own state in
            # _overlay_key starts the mean again), so that the mean shows them
            r.passes.insert(r.passes.index(r.get_pass("accumulate")), GizmoPass(r, self))
        except ManeError as exc:
            self.error = f"render settings refused: {exc}"
            if old is None:
                raise
            self.render_settings = dataclasses.replace(old.settings, size=self.render_settings.size)
            return
        if old is not None:
            old.release()
        self.renderer = r
        self.pass_history = {}

    def render_lights(self):
        """The lights in the renderer's order: shadow casters first."""
        casting = [l for l, c in zip(self.lights, self.casts) if c]
        return casting + [l for l, c in zip(self.lights, self.casts) if not c]

    def load_file(self, path) -> bool:
        """Load a dropped or named file: a groom (any hair format) or a head mesh. Errors go to
        ``self.error``; returns True when something was loaded."""
        from ..io import HAIR_FORMATS, MESH_FORMATS, load, load_mesh

        path = Path(path)
        suffix = path.suffix.lower()
        try:
            if suffix in HAIR_FORMATS:
                try:
                    groom = load(path)
                except ManeError:
                    if suffix not in MESH_FORMATS:
                        raise
                    groom = None
                if groom is not None:
                    n = groom.num_strands
                    self.load_scene(groom, self.head if self.groom is not None and self._head_is_users else None)
                    self.error = None
                    self.status = f"loaded {path.name}: {n} strands" + (
                        f" ({self.groom.num_strands} simulated)" if self.groom.num_strands != n else "")
                    return True
            if suffix in MESH_FORMATS:
                # a head stored in the groom's frame gets the groom's transform (mane.io.units)
                mesh = load_mesh(path, like=self.groom)
                self._head_is_users = True
                self.load_scene(self.groom, mesh)
                self.error = None
                self.status = f"loaded head {path.name}: {len(mesh.vertices)} vertices"
                return True
            raise UsageError(f"{path.name}: not a hair file ({', '.join(sorted(HAIR_FORMATS))}) "
                             f"or a mesh ({', '.join(MESH_FORMATS)})")
        except ManeError as exc:
            self.error = str(exc)
        except Exception as exc:    # a bad file must not take the window down
            self.error = f"{path.name}: {type(exc).__name__}: {exc}"
        return False

    _head_is_users = False

    # ------------------------------------------------------------------ simulation controls
    def _apply_motion(self, t: float) -> None:
        from ..sim import head_motion

        m = head_motion.preset(self.motion)(t)
        self.sim.set_head_transform(m)

    def set_motion(self, name: str) -> None:
        if name not in MOTIONS:
            raise UsageError(f"head motion must be one of {', '.join(MOTIONS)}")
        self.motion = name

    def reset(self) -> None:
        self.sim_time = 0.0
        self._apply_motion(0.0)
        self.sim.reset()
        self.renderer.set_head_transform(self.sim.state.head)
        self.renderer.strands_changed()

    def step_once(self) -> None:
        self._single_step = True

    def set_wind(self, on: bool | None = None) -> None:
        """Apply the wind controls (direction, strength, gusts) to the simulator's settings."""
        if on is not None:
            self.wind_on = bool(on)
        s = self.sim.settings
        if self.wind_on:
            az, el = math.radians(self.wind_azimuth), math.radians(self.wind_elevation)
            # the direction the wind blows toward; azimuth 0 blows from the face backward (-Z)
            d = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
            wind = dataclasses.replace(s.wind, velocity=tuple(d * self.wind_strength), gust=self.wind_gust,
                                       turbulence=self.wind_turbulence)
            drag = s.drag if s.drag > 0 else 1.0   # wind acts only through drag
        else:
            wind = dataclasses.replace(s.wind, velocity=(0.0, 0.0, 0.0), turbulence=0.0)
            drag = s.drag
        self.sim.settings = dataclasses.replace(s, wind=wind, drag=drag)

    def apply_style(self, name: str) -> None:
        sim_changes, render_changes = STYLE_PRESETS[name]
        try:
            self.sim.settings = dataclasses.replace(self.sim.settings, **sim_changes)
            self.render_settings = dataclasses.replace(self.render_settings, **render_changes)
            self.style = name
        except ManeError as exc:
            self.error = str(exc)

    def set_aa(self, name: str) -> None:
        from ..render.settings import aa_settings

        self.render_settings = dataclasses.replace(self.render_settings, **aa_settings(name))

    def aa_name(self) -> str:
        s = self.render_settings
        for name in AA_CHOICES:
            from ..render.settings import aa_settings

            a = aa_settings(name)
            if a["msaa"] == s.msaa and a["supersample"] == s.supersample and \
                    ("min_pixel_width" not in a or a["min_pixel_width"] == s.min_pixel_width):
                return name
        return "coverage" if s.msaa == 1 and s.supersample == 1 else "msaa4"

    # ------------------------------------------------------------------ the frame
    def frame(self, frame_dt: float | None = None) -> None:
        """Input, simulation, rendering and the panel: one frame into the back buffer."""
        from imgui_bundle import imgui

        now = time.perf_counter()
        real_dt = 1.0 / 60.0 if self._last is None else min(max(now - self._last, 1e-4), 0.25)
        self._last = now
        dt = real_dt if frame_dt is None else float(frame_dt)
        if self.recorder is not None:
            dt = 1.0 / self.recorder.fps     # a recording plays at real speed whatever the frame rate
        self._make_current()

        io = imgui.get_io()
        io.delta_time = max(real_dt, 1e-4)
        io.display_size = self.wnd.size
        imgui.new_frame()

        # the sphere: keys held
        if self._held & set("wasdqe") and self.sphere is not None:
            step = keyboard_offset(self._held & set("wasdqe"), self.orbit.camera(), self._sweep_radius * 1.2 * dt)
            self.move_sphere(self.sphere.transform[:3, 3] + step)

        # simulation
        sim_dt = dt * self.time_scale
        steps = 0
        if self.playing:
            self.sim_time += sim_dt
            self._animate()
            steps = self.sim.advance(sim_dt)
        elif self._single_step:
            self.sim_time += self.sim.settings.dt
            self._animate()
            self.sim.step()
            steps = 1
        self._single_step = False
        if steps:
            self.renderer.strands_changed()
        self.renderer.set_head_transform(self.sim.state.head)

        # panel (may change settings) then the scene
        if self.show_panel:
            self._panel()
        try:
            self._rebuild_renderer()
        except ManeError as exc:
            self.error = str(exc)
        aspect = self.render_size()[0] / self.render_size()[1]
        camera = self.orbit.camera()
        try:
            overlay = self._overlay_key()
            # sharpens while still (RenderSettings.accumulate); a change of the gizmos starts again
            self.renderer.render(camera, self.render_lights(), refine=overlay == self._last_overlay)
            self._last_overlay = overlay
        except ManeError as exc:
            self.error = str(exc)
        self._last_camera, self._last_aspect = camera, aspect
        self._blit()
        imgui.render()
        draw = imgui.get_draw_data()
        self.panel_drawn = bool(self.show_panel and draw.total_vtx_count > 0)
        self.imgui.render(draw)

        # outputs
        if self.recorder is not None:
            try:
                self.recorder.add(self.renderer.read_image())
            except Exception as exc:
                self.error = f"recording stopped: {exc}"
                self.toggle_recording()
        if self._screenshot_request is not False:
            path = self._screenshot_request
            self._screenshot_request = False
            self._save_screenshot(path)
        self._timings(real_dt)
        self.frames += 1
        if not self.auto_quality:
            self.auto_quality_state = "off"
        elif self.auto_quality_state == "off":
            self.auto_quality_state, self.frame_ms_history = "measuring", []
        if self.auto_quality and self.frames % 20 == 0:
            self._adapt_quality()

    def _animate(self) -> None:
        self._apply_motion(self.sim_time)
        if self.sweep and not self.dragging_sphere:
            phase = 2 * math.pi * self.sim_time / SWEEP_PERIOD
            self.sphere.move_to(self._sweep_centre + self._sweep_radius *
                                np.array([1.6 * math.cos(phase), 0.2, 1.6 * math.sin(phase)]))

    def _overlay_key(self) -> tuple:
        """What the gizmos draw besides the lights (GizmoPass): the sphere, the handles' place and
        what is hovered, dragged or selected."""
        sphere = self.sphere
        return (self.show_sphere, self.hover_sphere, self.dragging_sphere, self.show_light_handles, self.hover_light,
                self.dragging_light, self.selected_light, np.asarray(self.light_centre, float).tobytes(),
                float(self.light_distance), None if sphere is None else
                (np.asarray(sphere.transform, float).tobytes(), float(sphere.radius)))

    def _blit(self) -> None:
        out_fbo, tex = self.renderer.output_target()
        self._presenter.show(out_fbo, tex, self.wnd.fbo, bind=self.wnd.use)

    def _adapt_quality(self) -> None:
        """Every 20 frames, the frame rate of the last 20 (their mean, each frame counted at
        most 3 x the median: the renderer's warm-up and the panel's edits aside): below the
        target (below target x SETTLE_MARGIN until it first settles, so that it settles with a
        margin), take the next step of the demo's SOFTWARE_LADDER (once settled, only at the
        second such check running: a passing hiccup is no reason); STEP_UP x the target or more
        three checks running (the machine was busy when it stepped down, say), take the last
        step back, unless that level has fallen below the target twice.
        ``auto_quality_state`` and ``status`` say where it stands."""
        recent = np.asarray(self.frame_ms_history[-20:], float)
        if len(recent) < 20 or self.recorder is not None:
            return
        fps = 1000.0 / float(np.mean(np.minimum(recent, 3.0 * np.median(recent))))
        self.auto_quality_fps = fps
        level = len(self._undo)
        need = self.target_fps if self.auto_quality_state == "settled" else self.target_fps * SETTLE_MARGIN
        if fps >= need:
            self._slow_checks = 0
            if fps >= self.target_fps * STEP_UP and level and self._ladder_failures.get(level - 1, 0) < 2:
                self._fast_checks += 1
                if self._fast_checks >= 3:
                    self._step_up(fps)
                    return
            else:
                self._fast_checks = 0
            if self.auto_quality_state != "settled":
                self.auto_quality_state = "settled"
                steps = f"scaled down: {', '.join(self.quality_steps)}" if self.quality_steps else "full quality"
                self.status = f"holding {self.target_fps:g} fps: {fps:.1f} fps, {steps}"
            return
        self._fast_checks = 0
        if self.auto_quality_state == "settled" and self._slow_checks < 1:
            self._slow_checks += 1     # settled: a second slow check running before a step down
            return
        self._slow_checks = 0
        if self._ladder >= len(SOFTWARE_LADDER):
            if self.auto_quality_state != "floor":
                self.auto_quality_state = "floor"
                self.status = (f"below {self.target_fps:g} fps ({fps:.1f}) at the lowest quality: "
                               f"scaled down: {', '.join(self.quality_steps)}")
            return
        label, changes = SOFTWARE_LADDER[self._ladder]
        self._ladder_failures[level] = self._ladder_failures.get(level, 0) + 1
        self._ladder += 1
        self._undo.append({k: getattr(self.render_settings, k) for k in changes})
        self.render_settings = dataclasses.replace(self.render_settings, **changes)
        self.quality_steps.append(label)
        self.frame_ms_history = []
        self.auto_quality_state = "scaling"
        self.status = f"below {self.target_fps:g} fps ({fps:.1f}): scaled down: {', '.join(self.quality_steps)}"

    def quality_report(self) -> str:
        """One line on the auto-scaler: its state, the frame rate it measured, the steps taken."""
        steps = f"scaled down: {', '.join(self.quality_steps)}" if self.quality_steps else "full quality"
        if self.auto_quality_state == "off":
            return f"auto quality off ({steps})"
        measured = f" at {self.auto_quality_fps:.1f} fps" if self.auto_quality_fps else ""
        return f"auto quality {self.auto_quality_state}{measured} (target {self.target_fps:g}): {steps}"

    def _step_up(self, fps: float) -> None:
        self.render_settings = dataclasses.replace(self.render_settings, **self._undo.pop())
        self._ladder -= 1
        label = self.quality_steps.pop()
        self._fast_checks = 0
        self.frame_ms_history = []
        self.auto_quality_state = "scaling"
        self.status = f"{fps:.1f} fps: scaled back up (took back {label})"

    def _timings(self, real_dt: float) -> None:
        ms = real_dt * 1e3
        if self.frames > 0:   # the first frame's time is a guess
            self.frame_ms_history = (self.frame_ms_history + [ms])[-120:]
            recent = self.frame_ms_history[-30:]
            self.fps = 1000.0 * len(recent) / sum(recent)
        prof = self.renderer.profiler
        for name in prof.names():
            s = prof.samples(name)
            if s:
                self.pass_history[name] = (self.pass_history.get(name, []) + [s[-1]])[-120:]
        sp = getattr(self.sim, "_profiler", None)
        if sp is not None:
            for name in sp.names():
                s = sp.samples(name)
                if s:
                    self.pass_history[name] = (self.pass_history.get(name, []) + [s[-1]])[-120:]

    def run(self, max_frames: int | None = None, seconds: float | None = None) -> int:
        """The event loop, until the window closes (or ``max_frames`` / ``seconds`` pass)."""
        start = time.perf_counter()
        n = 0
        while not self.wnd.is_closing:
            self.frame()
            self.wnd.swap_buffers()
            n += 1
            if max_frames is not None and n >= max_frames:
                break
            if seconds is not None and time.perf_counter() - start >= seconds:
                break
        return n

    # ------------------------------------------------------------------ sphere
    def move_sphere(self, centre) -> None:
        c = np.asarray(centre, np.float64).reshape(3)
        if np.all(np.isfinite(c)):
            self.sphere.move_to(c)

    def sphere_screen_position(self) -> tuple[float, float]:
        """Where the sphere's centre is, in window pixels (top-left origin)."""
        from .picking import project

        w, h = self.wnd.size
        return project(self.orbit.camera(), self.sphere.transform[:3, 3], w, h)

    def _pick_sphere(self, x, y):
        w, h = self.wnd.size
        ray = pixel_ray(self.orbit.camera(), x, y, w, h)
        if self.sphere is None or not self.show_sphere:
            return ray, None
        return ray, ray_sphere(ray, self.sphere.transform[:3, 3], self.sphere.radius)

    # ------------------------------------------------------------------ events
    def _ui_wants_mouse(self) -> bool:
        from imgui_bundle import imgui

        return self.show_panel and imgui.get_io().want_capture_mouse

    def _ui_wants_keyboard(self) -> bool:
        from imgui_bundle import imgui

        return self.show_panel and imgui.get_io().want_capture_keyboard

    def resize(self, width: int, height: int) -> None:
        self._use_imgui()
        self.imgui.resize(width, height)

    def key_event(self, key, action, modifiers) -> None:
        self._use_imgui()
        keys = self.wnd.keys
        self.imgui.key_event(key, action, modifiers)
        self._mods = (bool(getattr(modifiers, "shift", False)), bool(getattr(modifiers, "ctrl", False)),
                      bool(getattr(modifiers, "alt", False)))
        letters = {getattr(keys, c.upper()): c for c in "wasdqe"}
        if action == keys.ACTION_RELEASE:
            if key in letters:
                self._held.discard(letters[key])
            return
        if action != keys.ACTION_PRESS or self._ui_wants_keyboard():
            return
        try:
            if key in letters:
                self._held.add(letters[key])
            elif key == keys.SPACE:
                self.playing = not self.playing
            elif key == keys.N:
                self.step_once()
            elif key == keys.R:
                self.reset()
            elif key == keys.F:
                self.orbit.reset()
            elif key == keys.H:
                self.show_panel = not self.show_panel
            elif key == keys.M:
                self.motion = MOTIONS[(MOTIONS.index(self.motion) + 1) % len(MOTIONS)]
            elif key == keys.F12:
                self.screenshot()
            elif key == keys.F9:
                self.toggle_recording()
        except ManeError as exc:
            self.error = str(exc)

    def mouse_position_event(self, x, y, dx, dy) -> None:
        self._use_imgui()
        self.imgui.mouse_position_event(x, y, dx, dy)
        if not self._ui_wants_mouse():
            self.hover_light = self.pick_light(x, y)
            self.hover_sphere = self.hover_light is None and self._pick_sphere(x, y)[1] is not None

    def mouse_press_event(self, x, y, button) -> None:
        self._use_imgui()
        self.imgui.mouse_press_event(x, y, button)
        self._buttons.add(button)
        if self._ui_wants_mouse():
            self._drag_mode = "ui"
            return
        shift, ctrl, _ = self._current_mods()
        if button == 1 and ctrl:
            self._drag_mode = "light"
        elif button == 1 and shift:
            self._drag_mode = "pan"
        elif button == 1:
            ray, t = self._pick_sphere(x, y)
            grabbed = self.pick_light(x, y)
            if grabbed is not None:
                self._drag_mode = "light_handle"
                self.selected_light = self.dragging_light = grabbed
                pos = self.light_handle_position(grabbed)
                if self.lights[grabbed].is_point:
                    self._drag = PlaneDrag.start(ray, pos, self.orbit.camera().forward)
                else:
                    self._drag = SphereDrag.start(ray, self.light_centre, self.light_distance, pos)
            elif t is not None:
                self._drag_mode = "sphere"
                self.dragging_sphere = True
                self._drag = PlaneDrag.start(ray, self.sphere.transform[:3, 3], self.orbit.camera().forward)
            else:
                self._drag_mode = "orbit"
        else:
            self._drag_mode = "pan"

    def _current_mods(self):
        m = getattr(self.wnd, "modifiers", None)
        if m is not None and (m.shift or m.ctrl or m.alt):
            return bool(m.shift), bool(m.ctrl), bool(m.alt)
        return self._mods

    def mouse_drag_event(self, x, y, dx, dy) -> None:
        self._use_imgui()
        self.imgui.mouse_drag_event(x, y, dx, dy)
        mode = self._drag_mode
        if mode == "sphere" and self._drag is not None:
            w, h = self.wnd.size
            c = self._drag.move(pixel_ray(self.orbit.camera(), x, y, w, h))
            if c is not None:
                self.move_sphere(c)
        elif mode == "orbit":
            self.orbit.orbit(dx, dy)
        elif mode == "pan":
            self.orbit.pan(dx, dy, self.wnd.size[1])
        elif mode == "light" and self.lights:
            self._turn_light(dx, dy)
        elif mode == "light_handle" and self._drag is not None and self.dragging_light is not None \
                and self.dragging_light < len(self.lights):
            w, h = self.wnd.size
            self._drag_light_to(self.dragging_light, pixel_ray(self.orbit.camera(), x, y, w, h))

    def mouse_release_event(self, x, y, button) -> None:
        self._use_imgui()
        self.imgui.mouse_release_event(x, y, button)
        self._buttons.discard(button)
        if not self._buttons:
            self._drag_mode = None
            self._drag = None
            self.dragging_sphere = False
            self.dragging_light = None

    def mouse_scroll_event(self, x_offset, y_offset) -> None:
        self._use_imgui()
        self.imgui.mouse_scroll_event(x_offset, y_offset)
        if not self._ui_wants_mouse():
            self.orbit.zoom(y_offset)

    def unicode_char_entered(self, char) -> None:
        self._use_imgui()
        self.imgui.unicode_char_entered(char)

    def files_dropped_event(self, x, y, paths) -> None:
        for p in paths:
            self.load_file(p)

    # ------------------------------------------------------------------ light handles
    def light_handle_position(self, i: int) -> np.ndarray:
        """Where light ``i``'s handle is (m): a point light's position; for a directional light,
        the point ``light_distance`` from ``light_centre`` toward the light."""
        light = self.lights[i]
        if light.is_point:
            return np.asarray(light.vector, np.float64)
        return self.light_centre + self.light_distance * light.direction_to(self.light_centre)

    def light_handle_radius(self, position) -> float:
        """The world radius (m) that makes a handle at ``position`` HANDLE_PIXELS on screen."""
        cam = self.orbit.camera()
        depth = max(float(np.dot(np.asarray(position, float) - np.asarray(cam.eye), cam.forward)), cam.near)
        metres_per_pixel = 2.0 * depth * math.tan(math.radians(cam.fov_y) / 2.0) / max(self.wnd.size[1], 1)
        return HANDLE_PIXELS * metres_per_pixel

    def light_handle_screen_position(self, i: int) -> tuple[float, float] | None:
        """Light ``i``'s handle in window pixels (top-left origin); None behind the camera."""
        cam = self.orbit.camera()
        pos = self.light_handle_position(i)
        if not in_front(cam, pos):
            return None
        w, h = self.wnd.size
        return project(cam, pos, w, h)

    def pick_light(self, x, y) -> int | None:
        """The light whose handle is under window pixel (x, y) (the nearest to the eye when
        several are), or None."""
        if not (self.show_light_handles and self.lights) or self.orbit is None:
            return None
        cam = self.orbit.camera()
        best, best_depth = None, math.inf
        for i in range(len(self.lights)):
            xy = self.light_handle_screen_position(i)
            if xy is None or math.hypot(xy[0] - x, xy[1] - y) > PICK_PIXELS:
                continue
            depth = float(np.dot(self.light_handle_position(i) - np.asarray(cam.eye), cam.forward))
            if depth < best_depth:
                best, best_depth = i, depth
        return best

    def _drag_light_to(self, i: int, ray) -> None:
        light = self.lights[i]
        if light.is_point:
            p = self._drag.move(ray)
            if p is None or not np.all(np.isfinite(p)):
                return
            v = p
        else:
            v = self._drag.move(ray)
        self.lights[i] = dataclasses.replace(light, vector=tuple(float(x) for x in v))

    def _turn_light(self, dx, dy) -> None:
        i = min(self.selected_light, len(self.lights) - 1)
        light = self.lights[i]
        if light.is_point:
            right, up, _ = self.orbit.basis()
            scale = self.orbit.distance * 0.003
            v = np.asarray(light.vector) + right * dx * scale - up * dy * scale
        else:
            v = np.asarray(light.vector, float)
            v = v / np.linalg.norm(v)
            az = math.atan2(v[0], v[2]) + math.radians(dx * 0.5)
            el = max(-1.5, min(1.5, math.asin(max(-1.0, min(1.0, v[1]))) - math.radians(dy * 0.5)))
            v = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
        self.lights[i] = dataclasses.replace(light, vector=tuple(float(x) for x in v))

    # ------------------------------------------------------------------ capture
    def read_window(self) -> np.ndarray:
        """(H, W, 3) uint8 of the window's back buffer (the panel included), top row first."""
        fbo = self.wnd.fbo
        w, h = fbo.size
        raw = fbo.read(viewport=(0, 0, w, h), components=3, alignment=1)
        return np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1].copy()

    def screenshot(self, path=None) -> None:
        """Save the window (panel included) as a PNG at the end of the next frame (F12)."""
        self._screenshot_request = None if path is None else Path(path)

    def _save_screenshot(self, path) -> Path:
        from .recorder import save_screenshot

        try:
            self.last_screenshot = save_screenshot(self.read_window(), self.out_dir, path)
            self.status = f"screenshot {self.last_screenshot}"
        except Exception as exc:
            self.error = f"screenshot failed: {exc}"
        return self.last_screenshot

    def toggle_recording(self, path=None) -> Path | None:
        """Start or stop recording the rendered view to an MP4 (F9); returns the file."""
        from .recorder import Recorder

        if self.recorder is None:
            try:
                self.recorder = Recorder(self.out_dir, fps=30.0, path=path)
            except Exception as exc:
                self.error = f"cannot record: {exc}"
                return None
            self.status = f"recording {self.recorder.path}"
            return self.recorder.path
        rec, self.recorder = self.recorder, None
        self.last_recording = rec.stop()
        self.status = f"recorded {rec.frames} frames to {self.last_recording}"
        return self.last_recording

    # ------------------------------------------------------------------ panel
    def _panel(self) -> None:
        from .panel import draw_panel

        draw_panel(self)

    # ------------------------------------------------------------------ end
    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        from imgui_bundle import imgui

        self._make_current()
        if self.recorder is not None:
            self.toggle_recording()
        for obj in (self.renderer, self.sim):
            if obj is not None:
                try:
                    obj.release()
                except Exception:
                    pass
        try:
            self.imgui.shutdown()
        except Exception:
            pass
        try:
            imgui.destroy_context(self._imgui_ctx)
        except Exception:
            pass
        try:
            self.wnd.destroy()
        except Exception:
            pass
        from ..gpu.context import window_closed

        window_closed(self.ctx)   # later headless rendering gets a live context

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
