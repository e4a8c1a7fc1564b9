"""The scan-conversion form's tuner (render/passes/scan_form.py): FormChooser fed with made-up
timings (it picks the faster median, keeps the form in use unless the other beats it by MARGIN,
probes again after REPROBE frames, at once on a scene or settings change or a watched frame
far off its median, and never waits on a result), the site's glue with a fake timer (results
read only once ready), and on a renderer frames whose forms alternate under the tuner: the
per-sample buffers, the deep opacity maps and the images identical from frame to frame."""
from __future__ import annotations

import numpy as np
import pytest

import mane.render.passes.raster_segment as raster_segment
import mane.render.passes.scan_form as scan_form
from mane.render.passes.scan_form import FormChooser

KEY = object()   # stands for the settings object


@pytest.fixture(autouse=True)
def _own_disk_cache(tmp_path, monkeypatch):
    """Every test its own empty disk cache: the tuner keeps its decisions there
    (scan_form_memory.py), and a test's probe must not be skipped by another's."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("MANE_NO_CACHE", raising=False)


def run(chooser, ms, frames, sizes=(1000, 1), key=KEY, lag=0):
    """Drive ``chooser`` for ``frames`` frames, each timed frame's result (``ms[form]``, or
    ms(form, frame) when callable) delivered ``lag`` frames later; the forms used, in order."""
    forms, pending = [], []
    for i in range(frames):
        while pending and pending[0][0] <= i:
            _, ticket, t = pending.pop(0)
            chooser.record(ticket, t)
        form, ticket = chooser.next(key, sizes)
        forms.append(form)
        if ticket is not None:
            assert ticket[1] == form
            t = ms(form, i) if callable(ms) else ms[form]
            pending.append((i + 1 + lag, ticket, t))
    return forms


def settle_frames(samples):
    # two untimed first uses, 2 x samples timed frames, one frame for the last result
    return 2 + 2 * samples + 1


def test_picks_the_faster_form_by_median():
    c = FormChooser(1, samples=3)
    forms = run(c, {0: 2.0, 1: 3.0}, settle_frames(3))
    assert forms[:2] == [1, 0]            # each form's first (compiling) use, untimed
    assert forms[2:8] in ([0, 1] * 3, [1, 0] * 3)   # then alternately timed, 3 each
    assert not c.probing and c.choice == 0 and c.medians == [2.0, 3.0]
    c = FormChooser(0, samples=3)
    run(c, {0: 2.0, 1: 1.0}, settle_frames(3))
    assert c.choice == 1 and c.probes == 1


@pytest.mark.parametrize("ms, choice", [({0: 3.0, 1: 2.0, 2: 1.0}, 2), ({0: 1.0, 1: 2.0, 2: 3.0}, 0),
                                        ({0: 3.0, 1: 1.0, 2: 2.0}, 1), ({0: 3.0, 1: 2.0, 2: 1.95}, 1)])
def test_three_forms_keep_the_fastest(ms, choice):
    # the hair site: each form's first use untimed, then each timed in turn, the fastest median
    # kept unless the one in use is within MARGIN of it (1.95 against 2.0: not switched)
    c = FormChooser(1, forms=3, samples=3, margin=0.05)
    forms = run(c, ms, 3 + 3 * 3 + 1)
    assert forms[:3] == [1, 0, 2]
    timed = forms[3:12]
    assert all(timed.count(f) == 3 for f in (0, 1, 2))
    assert all(len(set(timed[i:i + 3])) == 3 for i in (0, 3, 6))   # in turn
    assert not c.probing and c.choice == choice and c.medians == [ms[0], ms[1], ms[2]]


def test_three_forms_probe_again_and_follow_the_times():
    c = FormChooser(1, forms=3, samples=2, reprobe=40, watch=0)
    run(c, {0: 3.0, 1: 2.0, 2: 1.0}, 3 + 6 + 1)
    assert c.choice == 2 and c.probes == 1
    forms = run(c, {0: 1.0, 1: 2.0, 2: 3.0}, 60)   # the times turn: the re-probe after 40 frames follows
    assert forms[:38] == [2] * 38 and c.probes == 2 and c.choice == 0
    # a scene change probes all three at once, the new settings with first uses again
    forms = run(c, {0: 3.0, 1: 1.0, 2: 2.0}, 3 + 6 + 1, key=object())
    assert forms[:3] == [0, 1, 2] and c.choice == 1


def test_median_ignores_one_outlier():
    # per-thread faster but for one hitch of 50 ms among its samples
    c = FormChooser(1, samples=5)
    run(c, lambda f, i: (50.0 if i == 4 else 2.0) if f == 0 else 2.5, settle_frames(5))
    assert c.choice == 0 and c.medians[0] == 2.0


# a GPU clocking up mid-probe (the H200's fresh close-ups: every form ~5x slower over its first
# frames, then its own speed from one frame to the next): per-thread 9.7, balanced 2.55, tiled 1.57
CLOSEUP = {0: 9.7, 1: 2.55, 2: 1.57}


def clock_step(step: int, slow: float = 5.0):
    return lambda f, i: CLOSEUP[f] * (slow if i < step else 1.0)


@pytest.mark.parametrize("step", range(3, 3 + 3 * 5 + 2))
def test_a_clock_step_mid_probe_is_waited_out(step):
    # the probe times every form again until each one's last five agree; a step in its last round
    # leaves every median slow alike (the order right), and the first watch probes again
    c = FormChooser(1, forms=3, samples=5)
    forms = run(c, clock_step(step), 3 + 3 * 5 * 4 + 60)
    assert forms[3 + 3 * 5 * 4:].count(2) >= 45
    assert not c.probing and c.choice == 2
    assert c.medians == pytest.approx([CLOSEUP[0], CLOSEUP[1], CLOSEUP[2]])


def test_without_waiting_a_clock_step_picks_the_slower_form():
    # the protocol before SETTLE: some steps leave balanced with the faster median (why SETTLE is)
    wrong = []
    for step in range(3, 3 + 3 * 5 + 2):
        c = FormChooser(1, forms=3, samples=5, settle_rounds=0)
        run(c, clock_step(step), 3 + 3 * 5 + 1)
        wrong.append(c.choice != 2)
    assert any(wrong)


def test_times_that_never_agree_decide_after_settle_rounds():
    # one form's times jump 1 <-> 3 ms every other frame: the probe times every form again for
    # settle_rounds rounds, then decides on the medians it has
    c = FormChooser(0, forms=2, samples=3, settle_rounds=4)
    forms = run(c, lambda f, i: (1.0 if i % 4 < 2 else 3.0) if f == 0 else 2.5, 2 + 2 * (3 + 4) + 1)
    assert not c.probing and c.probes == 1
    timed = forms[2:-1]
    assert timed.count(0) == timed.count(1) == 3 + 4


@pytest.mark.parametrize("faster, switch", [(0.97, False), (0.951, False), (0.94, True), (0.5, True)])
def test_hysteresis_keeps_the_form_in_use(faster, switch):
    c = FormChooser(1, samples=3, margin=0.05)
    run(c, {0: 10.0 * faster, 1: 10.0}, settle_frames(3))
    assert not c.probing
    assert c.choice == (0 if switch else 1)


def test_probes_again_after_reprobe_frames():
    c = FormChooser(1, samples=2, reprobe=50, watch=0)
    run(c, {0: 1.0, 1: 2.0}, settle_frames(2))
    assert c.choice == 0 and c.probes == 1
    # settled: no timing (watch 0) for reprobe - 1 frames, the choice used
    forms = []
    for _ in range(48):
        f, ticket = c.next(KEY, (1000, 1))
        assert ticket is None
        forms.append(f)
    assert set(forms) == {0} and not c.probing
    # then both are timed again (no compiling frames: both warm) and the times have turned
    f, ticket = c.next(KEY, (1000, 1))   # the 50th: timed again at once (both warm)
    assert ticket is not None and c.probing
    c.record(ticket, {0: 3.0, 1: 2.0}[f])
    forms = run(c, {0: 3.0, 1: 2.0}, 2 * 2 + 2)
    assert {0, 1} <= set(forms)
    assert c.probes == 2 and c.choice == 1 and not c.probing


@pytest.mark.parametrize("sizes, probes", [((2500, 1), True), ((400, 1), True), ((1000, 3), True),
                                           ((1900, 1), False), ((600, 2), False), ((1000, 1), False)])
def test_a_scene_change_probes_at_once(sizes, probes):
    c = FormChooser(1, samples=2, watch=0)
    run(c, {0: 1.0, 1: 2.0}, settle_frames(2))
    epoch = c.epoch
    form, ticket = c.next(KEY, sizes)
    assert c.probing == probes
    assert (c.epoch != epoch) == probes
    if probes:   # both warm: timed at once
        assert ticket is not None
    else:
        assert ticket is None and form == 0


def test_new_settings_probe_with_first_uses_again():
    c = FormChooser(1, samples=2, watch=0)
    run(c, {0: 1.0, 1: 2.0}, settle_frames(2))
    same = type("S", (), {"__eq__": lambda a, b: True, "__hash__": lambda a: 0})()
    c.next(same, (1000, 1))    # an equal settings object: nothing changes
    assert not c.probing
    forms = run(c, {0: 2.0, 1: 1.0}, settle_frames(2), key=object())
    assert forms[:2] == [0, 1]   # the form in use first, each untimed (new programs may compile)
    assert c.choice == 1


def test_never_blocks_on_late_results():
    # results 6 frames late: once every sample is in flight the chooser runs its form untimed
    # (never waits), and decides when they come
    c = FormChooser(1, samples=3)
    forms = run(c, {0: 1.0, 1: 2.0}, 16, lag=6)
    assert forms[8:14] == [1] * 6    # every sample in flight: the form in use, untimed
    assert forms[14:] == [0, 0]      # the last result (frame 7's) read at frame 14
    assert not c.probing and c.choice == 0


def test_no_free_timer_runs_untimed():
    c = FormChooser(1, samples=2)
    run(c, {0: 1.0, 1: 2.0}, 2)
    for _ in range(10):
        assert c.next(KEY, (1000, 1), can_time=False) == (1, None)
    assert c.probing


def test_lost_and_stale_results():
    c = FormChooser(1, samples=2, watch=0)
    run(c, {0: 1.0, 1: 2.0}, 2)
    _, t0 = c.next(KEY, (1000, 1))
    c.record(t0, None)          # lost: asked for again
    f, t1 = c.next(KEY, (1000, 1))
    assert t1 is not None and c._out == [0, 1]   # the lost one no longer in flight: asked for again
    f, t2 = c.next(KEY, (1000, 1))
    assert t2[1] == t0[1]
    c.next(KEY, (5000, 1))      # a scene change: a new probe
    c.record(t1, 0.001)         # from the old probe: ignored
    assert c.probing and all(len(g) == 0 for g in c._got)


def test_watched_frame_far_off_probes_again():
    c = FormChooser(1, samples=2, watch=10, reprobe=1000)
    run(c, {0: 1.0, 1: 2.0}, settle_frames(2))
    tickets = []
    for _ in range(30):
        f, t = c.next(KEY, (1000, 1))
        if t is not None:
            tickets.append(t)
            assert t[1] == 0 == f and t[2]   # the chosen form, watched
    assert len(tickets) == 3
    c.record(tickets[0], 1.5)   # within RESCALE of its median: kept
    assert not c.probing
    c.record(tickets[1], 2.5)   # 2.5x: the scene changed under it
    assert c.probing
    run(c, {0: 3.0, 1: 2.0}, 2 * 2 + 1)
    assert c.choice == 1


# --------------------------------------------------------------------------- the site, on GL
class FakeTimer:
    """Stands for QueryTimer: ``ms[form]`` for the site's timed form, ready ``lag`` polls
    after it stopped (``lag`` None: never)."""
    ok = True

    def __init__(self, site, ms, pool=4, lag=0):
        self.site, self.ms, self.lag = site, ms, lag
        self.slots = {}
        self.pool = pool
        self.reads = 0

    def free(self):
        return len(self.slots) < self.pool

    def start(self):
        slot = next(i for i in range(self.pool) if i not in self.slots)
        self.slots[slot] = [self.ms[self.site.form], None]
        return slot

    def stop(self, slot):
        self.slots[slot][1] = 0

    def ready(self, slot):
        if self.lag is None:
            return False
        self.slots[slot][1] += 1
        return self.slots[slot][1] > self.lag

    def read(self, slot):
        assert self.ready(slot)
        self.reads += 1
        return self.slots.pop(slot)[0]


def test_site_never_waits_and_is_off_when_forced(gl, monkeypatch):
    monkeypatch.setattr(scan_form, "TUNE", True)
    monkeypatch.setattr(scan_form, "SAMPLES", 2)
    monkeypatch.setattr(raster_segment, "FORCED", None)
    site = scan_form.ScanFormSite(gl, "hair")
    site.timer = FakeTimer(site, {0: 2.0, 1: 1.0, 2: 3.0}, pool=3, lag=None)   # results never come
    forms = []
    for _ in range(12):
        forms.append(site.begin(KEY, (100, 1)))
        site.end()
    assert site.timer.reads == 0 and site.chooser.probing
    assert len(site.timer.slots) == 3          # the pool full, the rest untimed
    assert set(forms[5:]) == {site.chooser.choice}
    site.timer.lag = 1   # now ready two polls after
    for _ in range(20):
        site.begin(KEY, (100, 1))
        site.end()
        if not site.chooser.probing:
            break
    assert not site.chooser.probing and site.current() == 1 and site.stats()["form"] == "balanced"
    assert site.stats()["ms"] == {"per_thread": 2.0, "balanced": 1.0, "tiled": 3.0}
    monkeypatch.setattr(raster_segment, "FORCED", 1)     # forced: no tuning
    assert not site.tuning() and site.begin(KEY, (100, 1)) == 1 and site.current() == 1
    monkeypatch.setattr(raster_segment, "FORCED", 2)     # the tiled form: the hair site's alone
    assert site.begin(KEY, (100, 1)) == 2 and site.stats()["form"] == "tiled"
    assert scan_form.ScanFormSite(gl, "dom").begin(KEY, (100, 1)) == 1
    monkeypatch.setattr(raster_segment, "FORCED", None)
    monkeypatch.setattr(scan_form, "TUNE", False)        # off: the fixed rule
    assert site.begin(KEY, (100, 1)) == raster_segment.balance_for(gl)


def test_tuner_off_on_cpu_rasterisers_unless_asked(gl, monkeypatch):
    from mane.gpu.context import is_software_renderer

    if not is_software_renderer(gl):
        pytest.skip("a CPU rasteriser's rule")
    monkeypatch.setattr(raster_segment, "FORCED", None)
    monkeypatch.setattr(scan_form, "TUNE", None)
    site = scan_form.ScanFormSite(gl, "hair")
    assert not site.tuning() and site.begin(KEY, (100, 1)) == 0 and site.timer is None


def _frames_alternating(gl, monkeypatch, ms_hair, ms_dom, frames=9, **kw):
    """Render ``frames`` frames with the tuner on (fake timers, 2 samples a form): each frame's
    forms, per-sample buffers, deep opacity maps, images, and the final stats."""
    from mane.grooming.scene import default_scene
    from mane.render import Renderer, RenderSettings

    from mane.render import light_key

    monkeypatch.setattr(scan_form, "TUNE", True)
    monkeypatch.setattr(scan_form, "SAMPLES", 2)
    monkeypatch.setattr(raster_segment, "FORCED", None)
    monkeypatch.setattr(light_key, "KEEP", False)   # the deep opacity dispatches every frame, as with moving hair
    groom, head = default_scene(num_guides=120, points=10, subdivisions=3)
    r = Renderer(RenderSettings(**{"size": (120, 90), "msaa": 4, "rasterizer": "compute", "shadows": "deep_opacity",
                                   "shadow_map_size": 128, "strands_per_guide": 3, "width": 0.004, **kw}),
                 ctx=gl, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        cam = r.default_camera(25.0, distance_scale=0.3, points=None)
        sites = r.scan_forms
        sites.hair.timer = FakeTimer(sites.hair, ms_hair)
        sites.dom.timer = FakeTimer(sites.dom, ms_dom)
        sites.dom_z0.timer = FakeTimer(sites.dom_z0, {f: ms_dom[1 - f] for f in ms_dom})   # the other way
        hc = r.get_pass("hair_compute")
        hc.capture = True
        out = []
        for _ in range(frames):
            img = r.render_image(cam)
            out.append(dict(forms=(sites.hair.form, sites.dom.form, sites.dom_z0.form), bufs={k: v.copy() for k, v in hc.captured.items()},
                            dom=r.get_pass("deep_opacity").read(), image=img))
        return out, r.stats()
    finally:
        r.release()


def test_alternating_forms_give_identical_frames(gl, monkeypatch):
    from test_render_compute_balance import assert_cover_equal

    # per-thread faster at the hair site and the deep opacity z0, balanced at its layers
    # (the hair site's three forms: 3 first uses and 6 timed frames, decided at the 10th)
    frames, stats = _frames_alternating(gl, monkeypatch, {0: 1.0, 1: 2.0, 2: 3.0}, {0: 3.0, 1: 1.0}, frames=10)
    hair_forms = [f["forms"][0] for f in frames]
    dom_forms = [f["forms"][1] for f in frames]
    z0_forms = [f["forms"][2] for f in frames]
    assert {0, 1, 2} <= set(hair_forms[:6]) and {0, 1} <= set(dom_forms[:6]) and {0, 1} <= set(z0_forms[:6])
    assert any(a != b for a, b in zip(hair_forms, hair_forms[1:]))
    # each deep opacity dispatch its own choice: the layers balanced, z0 per thread
    assert hair_forms[-1] == 0 and dom_forms[-1] == 1 and z0_forms[-1] == 0
    assert stats["scan_form"] == {"hair": "per_thread", "dom_z0": "per_thread", "dom": "balanced"}
    assert stats["scan_form_by"] == "tuner"
    first = frames[0]
    assert (first["bufs"]["ids"] >= 0).sum() > 100 and (first["dom"][..., 3] < 1e8).sum() > 300
    for f in frames[1:]:
        np.testing.assert_array_equal(f["bufs"]["ids"], first["bufs"]["ids"])
        assert_cover_equal(f["bufs"]["cover"], first["bufs"]["cover"])
        np.testing.assert_array_equal(f["dom"], first["dom"])
        np.testing.assert_array_equal(f["image"], first["image"])


def test_a_frame_that_raised_loses_its_time_only(gl, monkeypatch):
    # begin() without end() (the frame raised between them): the next begin stops the open
    # timing, drops its result and asks for that sample again
    monkeypatch.setattr(scan_form, "TUNE", True)
    monkeypatch.setattr(scan_form, "SAMPLES", 2)
    monkeypatch.setattr(raster_segment, "FORCED", None)
    site = scan_form.ScanFormSite(gl, "dom")
    site.timer = FakeTimer(site, {0: 2.0, 1: 1.0}, pool=4, lag=0)
    for _ in range(2):   # the untimed first uses
        site.begin(KEY, (100, 1))
        site.end()
    site.begin(KEY, (100, 1))          # timed, never ended
    assert sum(site.chooser._out) == 1
    site.begin(KEY, (100, 1))          # drops it, times another
    site.end()
    assert sum(site.chooser._out) == 1 and site.timer.reads == 1   # the dropped one read, not recorded
    for _ in range(6):
        site.begin(KEY, (100, 1))
        site.end()
    assert not site.chooser.probing and site.current() == 1
    assert site.chooser.medians == [2.0, 1.0]


# --------------------------------------------------------------------------- decisions kept on disk
def _settle_site(gl, name, ms, sizes=(100, 1), key=KEY):
    site = scan_form.ScanFormSite(gl, name)
    site.timer = FakeTimer(site, ms, pool=4, lag=0)
    forms = []
    for _ in range(30):
        forms.append(site.begin(key, sizes))
        site.end()
        if site.chooser.probes:
            break
    assert site.chooser.probes == 1 and not site.chooser.probing
    return site, forms


def test_a_kept_decision_starts_a_fresh_site_on_it(gl, monkeypatch):
    """A probe's decision is kept on disk; a fresh site (a second launch) with the same key starts
    on it at its first frame (no probe, no first use of the other form); another size, site or
    no cache: it probes as before."""
    monkeypatch.setattr(scan_form, "TUNE", True)
    monkeypatch.setattr(scan_form, "SAMPLES", 2)
    monkeypatch.setattr(raster_segment, "FORCED", None)
    default = raster_segment.balance_for(gl)
    other = 1 - default
    ms = {default: 2.0, other: 1.0, 2: 3.0}   # the fixed rule's form slower: the probe switches
    first, forms = _settle_site(gl, "hair", ms)
    assert first.chooser.choice == other and default in forms and not first.chooser.recalled

    fresh = scan_form.ScanFormSite(gl, "hair")
    fresh.timer = FakeTimer(fresh, ms, pool=4, lag=0)
    got = []
    for _ in range(10):
        got.append(fresh.begin(KEY, (100, 1)))
        fresh.end()
    assert got == [other] * 10                 # its first frame already on the kept form
    assert not fresh.chooser.probing and fresh.chooser.recalled and fresh.chooser.probes == 0
    assert fresh.chooser.medians == [ms[0], ms[1], ms[2]]
    assert fresh.stats()["recalled"] is True and fresh.current() == other

    for name, sizes in (("hair", (1000, 1)), ("hair", (100, 2)), ("dom", (100, 1))):
        site = scan_form.ScanFormSite(gl, name)
        site.timer = FakeTimer(site, ms, pool=4, lag=0)
        assert site.begin(KEY, sizes) == default and site.chooser.probing, (name, sizes)
        site.end()

    monkeypatch.setenv("MANE_NO_CACHE", "1")   # the cache off: nothing recalled (nor kept)
    site = scan_form.ScanFormSite(gl, "hair")
    site.timer = FakeTimer(site, ms, pool=4, lag=0)
    assert site.begin(KEY, (100, 1)) == default and site.chooser.probing


def test_a_kept_decision_is_still_checked(gl, monkeypatch):
    """A recalled form is watched against its kept median: a watched frame RESCALE x off probes
    again, and the new decision replaces the kept one for the next run."""
    monkeypatch.setattr(scan_form, "TUNE", True)
    monkeypatch.setattr(scan_form, "SAMPLES", 2)
    monkeypatch.setattr(scan_form, "WATCH", 3)
    monkeypatch.setattr(raster_segment, "FORCED", None)
    default = raster_segment.balance_for(gl)
    other = 1 - default
    _settle_site(gl, "dom", {default: 2.0, other: 1.0})
    # the next run's GPU finds the kept form 5x slower than its median, the other faster
    site = scan_form.ScanFormSite(gl, "dom")
    site.timer = FakeTimer(site, {default: 2.0, other: 5.0}, pool=4, lag=0)
    forms = []
    for _ in range(30):
        forms.append(site.begin(KEY, (100, 1)))
        site.end()
    assert forms[0] == other and site.chooser.recalled
    assert site.chooser.probes == 1 and site.chooser.choice == default
    fresh = scan_form.ScanFormSite(gl, "dom")
    fresh.timer = FakeTimer(fresh, {default: 2.0, other: 5.0}, pool=4, lag=0)
    assert fresh.begin(KEY, (100, 1)) == default and fresh.chooser.recalled


def test_memory_key_covers_gpu_driver_settings_and_sizes():
    from mane.render.passes import scan_form_memory as mem

    class Ctx:
        def __init__(self, **info):
            self.info = {"GL_RENDERER": "NVIDIA H200/PCIe/SSE2", "GL_VENDOR": "NVIDIA Corporation",
                         "GL_VERSION": "4.6.0 NVIDIA 580.159.04", **info}

    base = mem.key(Ctx(), "hair", "settings", (1000, 1))
    assert base == mem.key(Ctx(), "hair", "settings", (1000, 1))
    others = [mem.key(Ctx(GL_VERSION="4.6.0 NVIDIA 590.1"), "hair", "settings", (1000, 1)),
              mem.key(Ctx(GL_RENDERER="NVIDIA A100"), "hair", "settings", (1000, 1)),
              mem.key(Ctx(), "dom", "settings", (1000, 1)), mem.key(Ctx(), "hair", "other", (1000, 1)),
              mem.key(Ctx(), "hair", "settings", (1001, 1)), mem.key(Ctx(), "hair", "settings", (1000, 2))]
    assert base not in others and len(set(others)) == len(others)
    mem.remember(base, 1, [2.0, 1.0])
    assert mem.recall(base) == (1, [2.0, 1.0])
    assert mem.recall(others[0]) is None
    mem.remember(others[0], 0, [None, 1.0])      # an incomplete probe is not kept
    assert mem.recall(others[0]) is None
    mem.remember(others[1], 2, [2.0, 1.5, 1.0])  # a three-form site's: recalled with its count only
    assert mem.recall(others[1], 3) == (2, [2.0, 1.5, 1.0]) and mem.recall(others[1]) is None
    assert mem.recall(base, 3) is None
    assert {"raster_tiles.glsl", "raster_tiles_scan.comp", "raster_tiles.py"} <= set(mem.CODE_FILES)


def test_a_second_renderer_starts_on_the_kept_forms(gl, monkeypatch):
    """A renderer made after another decided (a second launch, its cache warm) draws its first
    frame with the kept forms at every site, and the same images."""
    default = raster_segment.balance_for(gl)
    other = 1 - default
    hair = {default: 2.0, other: 1.0, 2: 3.0}
    first, _ = _frames_alternating(gl, monkeypatch, hair, {default: 1.0, other: 3.0}, frames=10)
    assert first[-1]["forms"] == (other, default, other)   # hair, dom (layers), dom_z0
    second, stats = _frames_alternating(gl, monkeypatch, hair, {default: 1.0, other: 3.0}, frames=2)
    assert [f["forms"] for f in second] == [(other, default, other)] * 2
    for f in second:
        np.testing.assert_array_equal(f["image"], first[0]["image"])


def test_a_recalled_decision_takes_a_faster_first_watch_as_its_median():
    """A kept decision's medians come from an earlier run's first frames, maybe on a GPU not yet
    clocked up: the recalled run's first watched frame, when faster, scales them (no probe, which
    would first use the other forms: programs and buffers built mid-run); a later watch far off
    the new medians, or a slower first one beyond RESCALE, probes again."""
    c = FormChooser(0, samples=2, watch=10, reprobe=1000)
    c.settle(KEY, (1000, 1), 1, [4.0, 3.0])
    tickets = []
    for _ in range(30):
        f, t = c.next(KEY, (1000, 1))
        assert f == 1
        if t is not None:
            tickets.append(t)
    assert len(tickets) == 3
    c.record(tickets[0], 1.0)       # 3x faster than the kept median: rebased, not probed
    assert not c.probing and c.medians == [4.0 / 3.0, 1.0] and c.probes == 0
    c.record(tickets[1], 1.5)       # within RESCALE of the new median: kept
    assert not c.probing
    c.record(tickets[2], 0.4)       # 2.5x faster than the new median: a later watch probes
    assert c.probing

    slow = FormChooser(0, samples=2, watch=10, reprobe=1000)
    slow.settle(KEY, (1000, 1), 1, [4.0, 3.0])
    t = next(t for _ in range(30) if (t := slow.next(KEY, (1000, 1))[1]) is not None)
    slow.record(t, 7.0)             # a slower first watch beyond RESCALE still probes
    assert slow.probing and slow.medians == [4.0, 3.0]

    own = FormChooser(1, samples=2, watch=10, reprobe=1000)   # a decision of its own probe
    run(own, {0: 3.0, 1: 4.0}, settle_frames(2))
    t = next(t for _ in range(30) if (t := own.next(KEY, (1000, 1))[1]) is not None)
    own.record(t, 1.0)              # no rebase: 3x off its own median probes
    assert own.probing
