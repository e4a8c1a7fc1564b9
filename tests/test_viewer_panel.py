"""The viewer's parts that need no window: the generated panel's plan, camera control, picking,
the recorder."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest


def test_every_setting_gets_a_widget_from_its_dataclass():
    from mane.render import Light, RenderSettings
    from mane.render.shading import ShadingSettings
    from mane.sim import SimSettings, WindSettings
    from mane.viewer.panel import widget_plan

    from mane.viewer.panel import hidden

    for obj in (SimSettings(), WindSettings(), RenderSettings(), Light(), ShadingSettings()):
        plan = widget_plan(obj)
        # every field but those declared panel=False (the window sets the size, the lights shadow_lights)
        assert set(plan) == {f.name for f in dataclasses.fields(obj)} - set(hidden(type(obj)))
        shown_only = {k for k, w in plan.items() if w.kind == "text"}
        # only structured values without an obvious widget are shown read-only
        assert shown_only <= {"colliders", "melanin", "sigma_a"}, (type(obj).__name__, shown_only)
    r = widget_plan(RenderSettings())
    assert r["shadows"].kind == "combo" and "deep_opacity" in r["shadows"].choices
    assert r["shading"].kind == "combo" and "marschner" in r["shading"].choices
    assert r["tone_mapping"].choices == ("aces", "reinhard", "none")
    assert r["msaa"].kind == "combo" and r["msaa"].choices == (1, 2, 4, 8, 16)   # what RenderSettings accepts
    assert set(hidden(RenderSettings)) == {"size", "shadow_lights"}
    assert r["hair_color"].kind == "optional_color" and r["background"].kind == "color"   # None: melanin
    assert r["draw_head"].kind == "checkbox" and r["segments"].kind == "slider_int"
    assert r["dom_layers"].kind == "drag3" and r["shading_options"].kind == "dict"
    if "oit" in r:    # order-independent transparency: the methods' constant gives the combo
        assert r["oit"].kind == "combo" and "k_buffer" in r["oit"].choices
    s = widget_plan(SimSettings())
    assert s["wind"].kind == "dataclass" and s["gravity"].kind == "drag3"
    assert s["length_method"].choices == ("dftl", "pbd")
    assert s["local_shape_stiffness"].kind == "slider_float" and (s["friction"].lo, s["friction"].hi) == (0, 1)
    assert widget_plan(Light())["kind"].choices == ("directional", "point")
    assert widget_plan(RenderSettings(hair_color=None))["hair_color"].kind == "optional_color"


def test_field_metadata_wins():
    from mane.viewer.panel import widget_plan

    @dataclasses.dataclass(frozen=True)
    class S:
        a: float = 0.5
        b: str = "x"
        c: int = 3

    @dataclasses.dataclass(frozen=True)
    class M:
        a: float = dataclasses.field(default=0.5, metadata={"range": (0.0, 10.0)})
        b: str = dataclasses.field(default="x", metadata={"choices": ("x", "y")})
        c: int = 3

    p, q = widget_plan(S()), widget_plan(M())
    assert p["a"].kind == "drag_float" and q["a"].kind == "slider_float" and q["a"].hi == 10.0
    assert p["b"].kind == "input_text" and q["b"].kind == "combo" and q["b"].choices == ("x", "y")
    assert p["c"].kind == "drag_int"


def test_field_docs_are_tooltips():
    from mane.render import RenderSettings
    from mane.viewer.panel import field_docs

    docs = field_docs(RenderSettings)
    assert "pixels" in docs["size"] and "head" in docs["draw_head"]   # every setting declares its help


def test_orbit_pan_zoom_maths():
    from mane.render.camera import Camera
    from mane.viewer.camera_control import OrbitControl

    cam = Camera.framing((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1), azimuth=30.0, elevation=15.0, aspect=16 / 9)
    oc = OrbitControl.from_camera(cam)
    assert np.allclose(oc.camera().eye, cam.eye) and oc.azimuth == pytest.approx(30.0)
    d = oc.distance
    oc.orbit(100, 0)
    assert oc.azimuth % 360.0 == pytest.approx(0.0, abs=1e-9) or oc.azimuth == pytest.approx(360.0)
    assert oc.distance == d
    oc.orbit(0, 1000)
    assert oc.elevation == 89.0
    oc.zoom(1)
    assert oc.distance == pytest.approx(d * 0.9)
    t = oc.target.copy()
    oc.pan(10, 0, 500)
    assert np.dot(oc.target - t, oc.basis()[0]) < 0      # the scene follows the mouse to the right
    oc.reset()
    assert np.allclose(oc.camera().eye, cam.eye)


def test_picking_hits_the_sphere_where_it_is_drawn():
    from mane.render.camera import Camera
    from mane.viewer.picking import PlaneDrag, keyboard_offset, pixel_ray, project, ray_sphere

    cam = Camera(eye=(0.3, 0.2, 1.0), target=(0.0, 0.0, 0.0), fov_y=35.0)
    w, h = 960, 540
    centre = np.array([0.05, -0.02, 0.1])
    x, y = project(cam, centre, w, h)
    ray = pixel_ray(cam, x, y, w, h)
    t = ray_sphere(ray, centre, 0.03)
    assert t is not None and np.linalg.norm(ray.at(t) - centre) == pytest.approx(0.03, abs=1e-6)
    assert ray_sphere(pixel_ray(cam, 5, 5, w, h), centre, 0.03) is None
    drag = PlaneDrag.start(ray, centre, cam.forward)
    new = drag.move(pixel_ray(cam, x + 100, y - 40, w, h))
    assert abs(np.dot(new - centre, cam.forward)) < 1e-9           # stays on the view plane
    assert project(cam, new, w, h) == pytest.approx((x + 100, y - 40), abs=1e-6)
    fwd = keyboard_offset({"w"}, cam, 0.01)
    assert np.linalg.norm(fwd) == pytest.approx(0.01) and fwd[1] == 0 and np.dot(fwd, cam.forward) > 0
    assert keyboard_offset({"e"}, cam, 0.02) == pytest.approx([0, 0.02, 0])
    assert np.allclose(keyboard_offset({"a", "d"}, cam, 0.01), 0)


def test_recorder_writes_an_mp4_that_decodes(tmp_path):
    import imageio.v2 as imageio

    from mane.viewer.recorder import Recorder, save_screenshot

    rec = Recorder(tmp_path, fps=10)
    for i in range(7):
        img = np.zeros((91, 121, 3), np.uint8)    # odd sides: cropped to even for libx264
        img[:, : 10 * (i + 1)] = 200
        rec.add(img)
    path = rec.stop()
    reader = imageio.get_reader(str(path))
    frames = [f for f in reader]
    reader.close()
    assert len(frames) == 7 and frames[0].shape == (90, 120, 3)
    shot = save_screenshot(np.full((4, 6, 3), 9, np.uint8), tmp_path)
    assert shot.suffix == ".png" and shot.is_file()


def test_import_mane_stays_light():
    import subprocess
    import sys

    code = ("import sys, mane; assert 'moderngl' not in sys.modules and 'mane.render' not in sys.modules; "
            "f = mane.render_image; assert callable(f) and 'mane.render' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_view_command_is_listed():
    from mane.app.cli import COMMANDS, build_parser

    assert "view" in COMMANDS
    args = build_parser("view").parse_args(["view", "hair.tfx", "--head", "h.obj", "--frames", "2"])
    assert args.groom == "hair.tfx" and args.head == "h.obj" and args.frames == 2
