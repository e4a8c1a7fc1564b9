"""The viewer under Xvfb: events sent programmatically, frames rendered, the window read back.

Xvfb is started here when no DISPLAY is set; without either, the tests skip. DISPLAY is set
only while these tests run (other tests, ``mane demo`` among them, keep seeing no display).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("moderngl_window")
pytest.importorskip("imgui_bundle")
pytest.importorskip("glfw")

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="session")
def x_display():
    """A display name: the user's, or a private Xvfb's (stopped at the end of the session)."""
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("no DISPLAY and no Xvfb to make one (apt-get install xvfb)")
    for n in range(91, 190):
        if not Path(f"/tmp/.X{n}-lock").exists() and not Path(f"/tmp/.X11-unix/X{n}").exists():
            break
    proc = subprocess.Popen([xvfb, f":{n}", "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 15
    while not Path(f"/tmp/.X11-unix/X{n}").exists():
        if proc.poll() is not None or time.time() > deadline:
            proc.kill()
            pytest.skip(f"Xvfb :{n} did not start")
        time.sleep(0.05)
    try:
        yield f":{n}"
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()


@pytest.fixture(scope="module")
def viewer(x_display, tmp_path_factory):
    from mane.viewer import Viewer

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("DISPLAY", x_display)
        v = Viewer(size=(960, 540), out_dir=tmp_path_factory.mktemp("viewer"), quality="software",
                   auto_quality=False)
        try:
            yield v
        finally:
            v.close()


@pytest.fixture(autouse=True)
def _display_env(x_display, monkeypatch):
    monkeypatch.setenv("DISPLAY", x_display)


def frames(v, n=3, dt=1 / 30):
    for _ in range(n):
        v.frame(dt)


class Mods:
    def __init__(self, shift=False, ctrl=False, alt=False):
        self.shift, self.ctrl, self.alt = shift, ctrl, alt


def key(v, name, mods=None):
    k = getattr(v.wnd.keys, name)
    v.key_event(k, v.wnd.keys.ACTION_PRESS, mods or Mods())
    v.key_event(k, v.wnd.keys.ACTION_RELEASE, mods or Mods())


def test_window_renders_scene_and_panel(viewer):
    from PIL import Image

    v = viewer
    frames(v, 4)
    assert v.error is None, v.error
    img = v.read_window()
    assert img.shape == (540, 960, 3)
    Image.fromarray(img).save("/tmp/viewer_window.png")
    assert v.panel_drawn
    # the scene: hair and head differ from the background right of the panel
    scene = img[:, 420:].reshape(-1, 3).astype(int)
    bg = np.round(np.array(v.render_settings.background) * 255).astype(int)
    assert (np.abs(scene - bg).sum(axis=1) > 30).mean() > 0.05
    # the panel drew: hiding it changes the left part of the window
    v.show_panel = False
    frames(v, 1)
    bare = v.read_window()
    assert not v.panel_drawn
    v.show_panel = True
    frames(v, 1)
    with_panel = v.read_window()
    diff = np.abs(with_panel[:400, :360].astype(int) - bare[:400, :360].astype(int)).sum(axis=2)
    assert (diff > 40).mean() > 0.1
    assert v.fps > 0 and any(k.startswith("sim.") for k in v.pass_history) and "hair" in v.pass_history


def _drag_target(v):
    """A point in dense hair, seen right of the panel, where the sphere fits without touching
    the head (it must not squeeze hair into the head)."""
    from mane.grooming.head import head_sdf
    from mane.viewer.picking import project

    free = v.sim.state.read("rest_positions")[:, 3] > 0
    p = v.sim.positions()[free].astype(float)
    r = v.sphere.radius
    cand = p[head_sdf(p) > 1.3 * r]
    cam = v.orbit.camera()
    front = (cand - np.asarray(cam.target)) @ cam.forward < 0    # the camera's side of the head: in view
    cand = cand[front] if front.sum() >= 5 else cand
    w, h = v.wnd.size
    xy = np.array([project(v.orbit.camera(), q, w, h) for q in cand])
    cand = cand[(xy[:, 0] > 450) & (xy[:, 0] < w - 200) & (xy[:, 1] > 60) & (xy[:, 1] < h - 60)]
    assert len(cand), "no hair away from the head in view"
    dense = (np.linalg.norm(cand[:, None, :] - p[None, :, :], axis=2) < r).sum(axis=1)
    return cand[int(np.argmax(dense))]


def test_drag_sphere_into_hair_pushes_every_particle_out(viewer):
    from mane.viewer.picking import project

    v = viewer
    v.sweep = False
    v.set_motion("none")
    v.playing = True
    v.sphere.radius = 0.025     # the panel's radius slider: a sphere that fits between hair and head
    frames(v, 3)
    target = _drag_target(v)
    # the sphere beside the hair, on the camera-facing plane through the target
    v.move_sphere(target + v.orbit.basis()[0] * 2.5 * v.sphere.radius)
    frames(v, 2)
    start = v.sphere.transform[:3, 3].copy()
    sx, sy = v.sphere_screen_position()
    w, h = v.wnd.size
    hx, hy = project(v.orbit.camera(), target, w, h)
    v.mouse_position_event(sx, sy, 0, 0)
    frames(v, 1)
    assert v.hover_sphere
    from PIL import Image

    Image.fromarray(v.read_window()).save("/tmp/viewer_sphere_before_drag.png")
    v.mouse_press_event(sx, sy, 1)
    assert v.dragging_sphere
    n = 8
    free = v.sim.state.read("rest_positions")[:, 3] > 0
    touching = 0
    for i in range(1, n + 1):   # drag in steps, the simulation running between them
        x, y = sx + (hx - sx) * i / n, sy + (hy - sy) * i / n
        v.mouse_drag_event(x, y, (hx - sx) / n, (hy - sy) / n)
        frames(v, 1)
        touching = max(touching, int((v.sphere.depth(v.sim.positions()[free]) > -0.003).sum()))
    assert touching > 10, "the sphere should push through the hair, touching strands"
    v.mouse_release_event(hx, hy, 1)
    assert not v.dragging_sphere
    moved = v.sphere.transform[:3, 3]
    assert np.linalg.norm(moved - start) > 0.5 * v.sphere.radius
    # the sphere sits over the hair as seen from the camera
    px, py = v.sphere_screen_position()
    assert abs(px - hx) < 3 and abs(py - hy) < 3
    frames(v, 6)
    pts = v.sim.positions()
    depth = v.sphere.depth(pts[free])
    from mane.grooming.head import head_sdf

    deepest = pts[free][int(np.argmax(depth))]
    assert depth.max() < 1e-3, (f"a particle is {depth.max() * 1000:.2f} mm inside the sphere, "
                                f"{head_sdf(deepest[None])[0] * 1000:.1f} mm from the head")
    Image.fromarray(v.read_window()).save("/tmp/viewer_sphere_in_hair.png")


def test_keyboard_moves_sphere(viewer):
    v = viewer
    v.sweep = False
    c0 = v.sphere.transform[:3, 3].copy()
    k = v.wnd.keys
    v.key_event(k.E, k.ACTION_PRESS, Mods())
    frames(v, 3)
    v.key_event(k.E, k.ACTION_RELEASE, Mods())
    c1 = v.sphere.transform[:3, 3].copy()
    assert c1[1] > c0[1] + 1e-3 and np.allclose(c1[[0, 2]], c0[[0, 2]])
    v.key_event(k.D, k.ACTION_PRESS, Mods())
    frames(v, 2)
    v.key_event(k.D, k.ACTION_RELEASE, Mods())
    right = v.orbit.basis()[0]
    assert np.dot(v.sphere.transform[:3, 3] - c1, right) > 1e-3
    frames(v, 2)
    c2 = v.sphere.transform[:3, 3].copy()
    frames(v, 2)
    assert np.allclose(v.sphere.transform[:3, 3], c2)   # released: it stays


def test_orbit_pan_zoom(viewer):
    v = viewer
    az, dist, target = v.orbit.azimuth, v.orbit.distance, v.orbit.target.copy()
    x, y = 900, 60     # empty background, away from the panel and the sphere
    v.mouse_press_event(x, y, 1)
    v.mouse_drag_event(x + 40, y, 40, 0)
    v.mouse_release_event(x + 40, y, 1)
    assert v.orbit.azimuth != az
    v.mouse_press_event(x, y, 2)
    v.mouse_drag_event(x - 30, y + 10, -30, 10)
    v.mouse_release_event(x - 30, y + 10, 2)
    assert not np.allclose(v.orbit.target, target)
    v.mouse_scroll_event(0, 2)
    assert v.orbit.distance < dist
    key(v, "F")
    assert v.orbit.azimuth == pytest.approx(az) and v.orbit.distance == pytest.approx(dist)
    frames(v, 1)


def test_play_pause_step_reset(viewer):
    v = viewer
    v.playing = True
    key(v, "SPACE")
    assert not v.playing
    steps = v.sim.state.steps
    frames(v, 2)
    assert v.sim.state.steps == steps
    key(v, "N")
    frames(v, 1)
    assert v.sim.state.steps == steps + 1
    key(v, "R")
    assert v.sim_time == 0.0 and v.sim.state.steps == 0
    key(v, "SPACE")
    frames(v, 2, dt=1 / 30)
    assert v.playing and v.sim.state.steps >= 2


def test_wind_motion_style_and_settings(viewer):
    from mane.errors import UsageError

    v = viewer
    v.set_wind(True)
    w = v.sim.settings.wind
    assert np.linalg.norm(w.velocity) > 0 and v.sim.settings.drag > 0 and w.gust == v.wind_gust
    v.set_wind(False)
    assert not v.sim.settings.wind.active
    for m in ("nod", "shake", "turn"):
        v.set_motion(m)
        frames(v, 1)
    assert not np.allclose(v.sim.state.head, np.eye(4))
    with pytest.raises(UsageError):
        v.set_motion("dance")
    v.set_motion("none")
    v.apply_style("curly")
    frames(v, 1)
    assert v.renderer.settings.curl_radius > 0
    # shading, shadow and AA choices rebuild the renderer
    v.render_settings = v.render_settings.replace(shadows="none", shading="kajiya_kay")
    v.set_aa("ssaa2")
    frames(v, 1)
    assert v.renderer.settings.shadows == "none" and v.renderer.settings.supersample == 2
    assert v.aa_name() == "ssaa2"
    v.set_aa("none")
    # melanin instead of RGB
    v.color_mode = "melanin"
    v.melanin = (8.0, 0.0)
    frames(v, 1)
    assert v.renderer.settings.hair_color is None
    assert v.renderer.settings.shading_options["melanin"] == (8.0, 0.0)
    v.color_mode = "rgb"
    v.apply_style("demo (soft, long)")
    v.render_settings = v.render_settings.replace(shadows="shadow_map")
    frames(v, 1)
    assert v.error is None, v.error


def test_lights_turn_and_cast(viewer):
    v = viewer
    before = v.lights[0].vector
    x, y = 900, 80
    ctrl = v.wnd.keys.LEFT_CTRL if hasattr(v.wnd.keys, "LEFT_CTRL") else v.wnd.keys.A
    v.key_event(ctrl, v.wnd.keys.ACTION_RELEASE, Mods(ctrl=True))   # modifiers come with key events
    v.mouse_press_event(x, y, 1)
    v.mouse_drag_event(x + 30, y - 20, 30, -20)
    v.mouse_release_event(x + 30, y - 20, 1)
    v._mods = (False, False, False)
    assert not np.allclose(v.lights[0].vector, before)
    v.casts = [True, True, False]
    frames(v, 1)
    assert v.renderer.settings.shadow_lights == 2
    v.casts = [False, False, False]
    frames(v, 1)
    assert v.renderer.settings.shadows == "none"
    v.casts = [True, False, False]
    frames(v, 1)
    assert v.renderer.settings.shadow_lights == 1 and v.renderer.settings.shadows != "none"


def test_settings_editor_refuses_bad_values(viewer):
    from mane.viewer.panel import SettingsEditor

    ed = SettingsEditor()
    s = viewer.sim.settings
    same, ok = ed._replace(s, dt=5.0)
    assert not ok and same is s and "dt" in ed.error
    new, ok = ed._replace(s, damping=2.0)
    assert ok and new.damping == 2.0 and ed.error is None


def test_dropped_files_load_or_show_an_error(viewer, tmp_path, shared_data_or_none):
    from mane import Groom, save
    from mane.render.scene import default_head

    v = viewer
    bad = tmp_path / "broken.tfx"
    bad.write_bytes(b"not a tfx file at all")
    v.files_dropped_event(0, 0, [str(bad)])
    frames(v, 1)
    assert v.error and "broken.tfx" in v.error
    v.files_dropped_event(0, 0, [str(tmp_path / "notes.txt")])
    assert "notes.txt" in v.error
    # a small groom: 20 straight strands hanging from a ring
    a = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    roots = np.stack([0.08 * np.cos(a), np.full(20, 0.1), 0.08 * np.sin(a)], 1)
    pts = roots[:, None, :] + np.linspace(0, -0.2, 8)[None, :, None] * np.array([0, 1, 0])
    path = tmp_path / "ring.npz"
    save(Groom(pts.reshape(-1, 3).astype(np.float32), np.full(20, 8, np.int32)), path)
    v.error = None
    v.files_dropped_event(0, 0, [str(path)])
    frames(v, 2)
    assert v.error is None, v.error
    assert v.sim.state.num_strands == 20 and v.head is None
    mesh_path = tmp_path / "head.obj"
    head = default_head(2)
    with open(mesh_path, "w") as f:
        for p in head.vertices:
            f.write(f"v {p[0]} {p[1]} {p[2]}\n")
        for t in head.faces + 1:
            f.write(f"f {t[0]} {t[1]} {t[2]}\n")
    v.files_dropped_event(0, 0, [str(mesh_path)])
    frames(v, 2)
    assert v.error is None, v.error
    assert v.head is not None and v.sim.state.num_strands == 20
    if shared_data_or_none is not None:
        v.files_dropped_event(0, 0, [str(shared_data_or_none / "tressfx" / "sintel_hair.tfx")])
        v.files_dropped_event(0, 0, [str(shared_data_or_none / "heads" / "sintel.obj")])
        frames(v, 3)
        assert v.error is None, v.error
        assert v.sim.state.num_strands == 228
        from PIL import Image

        Image.fromarray(v.read_window()).save("/tmp/viewer_sintel.png")
    v.load_scene(None, None)     # back to the default for the next tests
    v._head_is_users = False
    frames(v, 1)


@pytest.fixture
def shared_data_or_none():
    from pathlib import Path

    p = Path(__file__).resolve().parents[1].parent / "shared" / "data"
    return p if p.is_dir() else None


def test_screenshot_and_recording(viewer, tmp_path):
    import imageio.v2 as imageio

    v = viewer
    key(v, "F12")
    frames(v, 1)
    shot = v.last_screenshot
    assert shot is not None and shot.is_file() and shot.suffix == ".png"
    assert imageio.imread(shot).shape[:2] == (540, 960)
    v.screenshot("/tmp/viewer_screenshot.png")
    frames(v, 1)
    assert Path("/tmp/viewer_screenshot.png").is_file()
    key(v, "F9")
    assert v.recorder is not None
    frames(v, 5)
    key(v, "F9")
    assert v.recorder is None and v.last_recording.is_file()
    reader = imageio.get_reader(str(v.last_recording))
    video = [f for f in reader]
    reader.close()
    assert len(video) == 5 and video[0].shape == (540, 960, 3)
    assert "recorded 5 frames" in v.status


def test_demo_and_view_commands_open_the_window(x_display, tmp_path):
    """``mane demo`` opens the viewer when there is a display; ``mane view --frames``."""
    shot = tmp_path / "view.png"
    env = dict(os.environ, DISPLAY=x_display)
    env.pop("CI", None)
    cmd = [str(Path(os.sys.executable)), "-m", "mane", "view", "--frames", "3", "--screenshot", str(shot),
           "--out", str(tmp_path)]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert shot.is_file() and "3 frames" in r.stdout
    cmd = [str(Path(os.sys.executable)), "-m", "mane", "demo", "--window", "--seconds", "1.5", "--out", str(tmp_path)]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "the viewer on" in r.stdout and "frames per second" in r.stdout


def test_scales_quality_down_below_the_target_frame_rate(viewer):
    v = viewer
    before = v.renderer.settings
    v.auto_quality, v.target_fps = True, 10000.0     # unreachable: every check steps down
    v.frame_ms_history = []
    try:
        frames(v, 41)
    finally:
        v.auto_quality, v.target_fps = False, 15.0
    assert len(v.quality_steps) >= 1 and "scaled down" in v.status
    after = v.renderer.settings
    assert (after.segments, after.strands_per_guide) < (before.segments, before.strands_per_guide)
