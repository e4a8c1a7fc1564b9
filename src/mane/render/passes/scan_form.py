"""The scan-conversion form chosen per dispatch site by measurement (an autotuner, on GPUs).

raster_segment.glsl has forms (raster_segment.py, ``RASTER_BALANCE``) that leave the same
buffers bit for bit: 1, load-balanced, 2-3x faster on the H200's close-ups and 1M strands; 0, a
thread a segment, faster on the crowd of small alike heads (no imbalance to win back); 2, tiled
(raster_tiles.py: segments binned to screen tiles, each tile's visits in shared memory; the
hair site only): on the H200 with 16 x 16-sample tiles, frames 1.19x / 2.41x / 1.08x faster
than balanced in the 100k- and 1M-strand close-ups and at 1M strands, 1.17x slower on the
target frame. No simple geometric rule told those apart, so
each site times its forms and keeps the fastest:

``hair``
    hair_compute.py's whole raster section, three forms: the head's tile map, the dispatches
    and, in the balanced and tiled forms, the hair cull's split and occlusion map
    (occlusion_tiles.py) and the column cull (depth_tiles.py; the tiled form's own bounds),
    which follow the form.
``dom_z0``, ``dom``
    deep_opacity.py's two dom_raster.comp dispatches, each its own site: the nearest light depth
    (``dom_z0``) and the opacity layers (``dom``); the pack is the same in both forms. They
    differ: on the H200's 100k-strand close-up the per-thread form's z0 took 0.14 ms against the
    balanced form's 0.25, its layers 0.58 against 0.34 (one site for both chose balanced).

The OIT fill and the shadow map's hair depths keep the fixed rule (raster_segment.balance_for).
CPU rasterisers keep the per-thread form everywhere (the tuner is off there).

The protocol (``FormChooser``, pure Python): a probe first uses each form once untimed (its
program compiles), then times them in turn until each has ``SAMPLES`` results, and keeps the
fastest median, switching from the form in use only when that one is ``MARGIN`` faster (the
first probe starts from the fixed rule's form). The medians are compared only once every form's
last ``SAMPLES`` times agree among themselves within ``SETTLE`` x (the highest and the lowest
left out from five on): a GPU clocking up in the middle of a probe (H200: a 100k-strand close-up's
tiled form 8.5 ms, then 1.6 ms from one frame to the next; balanced 13 -> 2.55) had given the
form timed more often before the step a median from the slow clock, so the fresh runs of a
close-up kept the slower form in three of five. Until they agree, every form is timed once more
in turn and its oldest time dropped, for at most ``SETTLE_ROUNDS`` such rounds. Settled, it times the chosen form every
``WATCH`` frames and probes again after ``REPROBE`` frames, at once when the site's segment or
instance count moves by more than ``RESCALE`` x from the probe's, when the settings object
changes, or when a watched frame's time moves by more than ``RESCALE`` x from the chosen
median (a camera move from the crowd to a close-up). Times are pairs of GL_TIMESTAMP queries
from a fixed pool per site (``QueryTimer``), read only once available, a few frames late: the
CPU never waits, and a frame that finds the pool in use runs untimed.

A decision is kept on disk (scan_form_memory.py: keyed by the site, the GPU and driver, the
settings, the sizes and the forms' code): a site's first tuned frame in a later run with the
same key starts settled on it (``FormChooser.settle``), watched as after a probe of its own,
instead of probing its forms over its first frames. The kept medians come from that run's first
frames, on a GPU not yet clocked up (H200: balanced 4.92 ms at a first launch's probe, 3.27 ms
warm): a recalled run's first watched frame, when faster, scales them to itself instead of
probing (a probe would first use the other forms: programs and buffers built mid-run); a slower
one beyond ``RESCALE``, and any later watch, probes as before.

Off (the fixed rule, raster_segment.balance_for) where ``raster_segment.FORCED`` (or
``MANE_RASTER_BALANCE``) forces a form, on CPU rasterisers (llvmpipe: the per-thread form, and
its timer queries are unreliable), where the GL timer queries cannot be loaded, and while
``TUNE`` is False (benchmarks pinning a form). ``TUNE`` True tunes there too (tests, with a
fake timer on llvmpipe).
"""
from __future__ import annotations

import math
from collections import deque
from statistics import median

from ...gpu import replay as gl_replay
from ...gpu.capabilities import get_capabilities   # cached per context
from . import raster_segment, scan_form_memory

SAMPLES = 5       # timed frames per form a probe, compared by their medians
MARGIN = 0.05     # the other form must be this much faster (of the form in use's median) to switch
SETTLE = 1.25     # a form's times agree when their spread (trimmed from five on) is within this ratio
SETTLE_ROUNDS = 10  # rounds a probe times every form again, at most, waiting for its times to agree
REPROBE = 300     # frames a choice is kept before both forms are timed again
RESCALE = 2.0     # segment / instance count or watched time ratio that probes again at once
WATCH = 30        # frames between timings of the chosen form while settled (0: none)
POOL = 8          # timestamp query pairs per site (the GPU may be this many timed frames behind)
TUNE = None       # None: on GPUs with timer queries; True: everywhere (tests); False: off

FORM_NAMES = raster_segment.FORM_NAMES   # by RASTER_BALANCE
SITES = ("hair", "dom_z0", "dom")
SITE_FORMS = {"hair": 3, "dom_z0": 2, "dom": 2}     # forms 0 .. n - 1 each site chooses among


class FormChooser:
    """The choice of one site from the timings fed back to it (no GL). Each frame ``next(key,
    sizes)`` gives the form to dispatch and a ticket when that frame is to be timed; the time, when
    it arrives, goes back with ``record(ticket, ms)`` (None: lost). ``key`` is compared by
    identity, then equality (the settings); ``sizes`` (segments, instances) by ratio; ``forms``
    the number of forms (0 .. forms - 1)."""

    def __init__(self, default: int, *, forms: int = 2, samples: int = None, margin: float = None, reprobe: int = None,
                 rescale: float = None, watch: int = None, settle: float = None, settle_rounds: int = None):
        self.samples = max(1, int(SAMPLES if samples is None else samples))
        self.margin = float(MARGIN if margin is None else margin)
        self.agree = float(SETTLE if settle is None else settle)
        self.settle_rounds = max(0, int(SETTLE_ROUNDS if settle_rounds is None else settle_rounds))
        self.reprobe = max(1, int(REPROBE if reprobe is None else reprobe))
        self.rescale = float(RESCALE if rescale is None else rescale)
        self.watch = int(WATCH if watch is None else watch)
        self.forms = max(2, int(forms))
        self.choice = min(max(int(default), 0), self.forms - 1)
        self.medians = [None] * self.forms   # the last probe's, ms
        self.probes = 0               # probes decided
        self.recalled = False         # started settled on a kept decision (settle)
        self._rebase = False          # recalled, its first watch not yet back
        self.epoch = 0
        self.probing = True
        self._key = self._sizes = None
        self._warm = [False] * self.forms
        self._got = tuple([] for _ in range(self.forms))
        self._out = [0] * self.forms  # timed frames in flight this probe
        self._rounds = 0              # rounds this probe timed again for its times to agree
        self._last = self.choice      # the form last timed (the probe alternates)
        self._since = 0               # frames since the last decision

    def settle(self, key, sizes, form: int, medians) -> None:
        """Start settled on ``form`` for ``key`` and ``sizes`` (a decision an earlier run kept:
        scan_form_memory.py), with its ``medians`` (ms per form): no probe, the form watched
        against its median and probed again as after a probe of this chooser's own."""
        self._key, self._sizes = key, tuple(sizes)
        self.choice = int(form)
        self.medians = [None if m is None else float(m) for m in medians]
        self._warm[self.choice] = True
        self.probing = False
        self.recalled = True
        self._rebase = True
        self._since = 0

    @property
    def measured_on(self) -> tuple:
        """(key, sizes) of the dispatch the chooser's decision was measured on."""
        return self._key, self._sizes

    # ------------------------------------------------------------------ a frame
    def next(self, key, sizes, can_time: bool = True) -> tuple[int, tuple | None]:
        """(form, ticket or None) for this frame; ``can_time`` False: no timer free, so untimed."""
        if self._key is None:
            self._key, self._sizes = key, tuple(sizes)
        elif key is not self._key and key != self._key:
            self._key = key
            self._warm = [False] * self.forms   # new settings may compile new programs
            self._probe(sizes)
        elif self._moved(sizes):
            self._probe(sizes)
        if not self.probing:
            self._since += 1
            if self._since >= self.reprobe:
                self._probe(sizes)
            else:
                if can_time and self.watch > 0 and self._since % self.watch == 0:
                    return self.choice, (self.epoch, self.choice, True)
                return self.choice, None
        n = self.forms
        for f in (self.choice, *(g for g in range(n) if g != self.choice)):   # first uses compile: untimed
            if not self._warm[f]:
                self._warm[f] = True
                return f, None
        if not can_time:
            return self.choice, None
        have = [len(self._got[f]) + self._out[f] for f in range(n)]
        need = [f for f in range(n) if have[f] < self.samples]
        if not need:   # all issued: wait for the results
            return self.choice, None
        # the least timed, ties in turn after the form timed last
        f = min(need, key=lambda g: (have[g], (g - self._last - 1) % n))
        self._out[f] += 1
        self._last = f
        return f, (self.epoch, f, False)

    def quiet_next(self, can_time: bool = True) -> bool:
        """Whether ``next`` with the same key and sizes would give the form in use untimed
        and change nothing but the frame count (``skip``): settled, no watch and no probe due."""
        if self.probing or self._key is None:
            return False
        since = self._since + 1
        if since >= self.reprobe:
            return False
        return not (can_time and self.watch > 0 and since % self.watch == 0)

    def skip(self) -> None:
        """Count a frame that ``quiet_next`` said was quiet (a recorded frame played: frame_replay.py)."""
        self._since += 1

    def record(self, ticket, ms) -> None:
        """A timed frame's GPU milliseconds (None or not finite: lost, asked for again)."""
        epoch, form, watched = ticket
        if epoch != self.epoch:   # from before the probe now running
            return
        ok = ms is not None and math.isfinite(ms) and ms >= 0.0
        if watched:
            m = self.medians[form]
            if ok and not self.probing and m and form == self.choice:
                if self._rebase and ms < m:   # a recalled run's warm GPU: its medians scaled, no probe
                    self.medians = [None if x is None else x * ms / m for x in self.medians]
                elif not m / self.rescale <= ms <= m * self.rescale:
                    self._probe(self._sizes)
                self._rebase = False
            return
        self._out[form] -= 1
        if not ok:
            return
        self._got[form].append(float(ms))
        if self.probing and all(len(g) >= self.samples for g in self._got):
            if self._rounds < self.settle_rounds and not all(self._agree(g) for g in self._got):
                self._rounds += 1   # a clock changing mid-probe: every form once more, its oldest dropped
                for g in self._got:
                    del g[0]
                return
            self._decide()

    # ------------------------------------------------------------------ inside
    def _moved(self, sizes) -> bool:
        if sizes == self._sizes:
            return False
        for a, b in zip(sizes, self._sizes):
            a, b = max(float(a), 1.0), max(float(b), 1.0)
            if max(a / b, b / a) > self.rescale:
                return True
        return len(sizes) != len(self._sizes)

    def _agree(self, times) -> bool:
        """Whether a form's times lie within ``settle`` x of each other (the highest and the lowest
        left out from five times on: one hitch is the median's to ignore, not a clock's step)."""
        t = sorted(times)
        if len(t) >= 5:
            t = t[1:-1]
        return t[-1] <= t[0] * self.agree

    def _probe(self, sizes) -> None:
        self.epoch += 1
        self.probing = True
        self._rebase = False
        self._sizes = tuple(sizes)
        self._got = tuple([] for _ in range(self.forms))
        self._out = [0] * self.forms
        self._rounds = 0
        self._since = 0

    def _decide(self) -> None:
        m = [median(g) for g in self._got]
        best = min(range(self.forms), key=lambda f: m[f])
        if m[best] < m[self.choice] * (1.0 - self.margin):
            self.choice = best
        self.medians = m
        self.probes += 1
        self.probing = False
        self._since = 0


class QueryTimer:
    """``pool`` pairs of GL_TIMESTAMP queries made once: ``start()`` a free pair's slot (None:
    all in flight), ``stop(slot)``, ``ready(slot)`` without waiting, ``read(slot)`` the ms
    between the stamps (frees the slot; only once ready, so it does not wait)."""

    def __init__(self, ctx, pool: int = POOL):
        from ...gpu.profiler import TimestampQueries

        self._q = TimestampQueries(ctx)
        self.ok = bool(self._q.ok)
        self._pairs = [self._q.new_pair() for _ in range(int(pool))] if self.ok else []
        self._free = list(range(len(self._pairs)))

    def free(self) -> bool:
        return bool(self._free)

    def start(self):
        if not self._free:
            return None
        slot = self._free.pop()
        self._q.stamp(self._pairs[slot][0])
        return slot

    def stop(self, slot) -> None:
        self._q.stamp(self._pairs[slot][1])

    def ready(self, slot) -> bool:
        return self._q.available(self._pairs[slot][1])

    def read(self, slot) -> float:
        a, b = self._pairs[slot]
        ms = (self._q.result(b) - self._q.result(a)) / 1e6
        self._free.append(slot)
        return ms

    def release(self) -> None:
        self._q.release(self._pairs)
        self._pairs, self._free = [], []


class ScanFormSite:
    """One dispatch site: ``begin(key, sizes)`` the form for this frame's dispatches (timing
    them when the chooser asks), ``end()`` after them; ``current()`` the form without a frame."""

    def __init__(self, ctx, name: str):
        self.ctx = ctx
        self.name = name
        self.forms = SITE_FORMS[name]
        self.timer = None        # made on first use (tests put a fake one here)
        self.chooser = None      # FormChooser, made on the first tuned frame
        self._pending: deque = deque()   # (slot, ticket) stamped, not yet read
        self._open = None
        self._timer_ok = None
        self._software = None    # a CPU rasteriser (asked once)
        self.form = None         # the form of the last frame's dispatches
        self._kept = None        # (file name, form) of the decision on disk as last recalled or kept
        self._decided = 0        # the chooser's probes already kept

    def tuning(self) -> bool:
        """Whether this frame's form is the tuner's (else the fixed rule's, form_for)."""
        if raster_segment.FORCED is not None or TUNE is False:
            return False
        if TUNE is None:
            if self._software is None:
                self._software = bool(get_capabilities(self.ctx).is_software)
            if self._software:
                return False
        if self._timer_ok is None:
            if self.timer is None:
                self.timer = QueryTimer(self.ctx)
            self._timer_ok = bool(getattr(self.timer, "ok", True))
        return self._timer_ok

    def current(self) -> int:
        if self.tuning() and self.chooser is not None:
            return self.chooser.choice
        return raster_segment.form_for(self.ctx, self.forms)

    def begin(self, key, sizes) -> int:
        if not self.tuning():
            self.form = raster_segment.form_for(self.ctx, self.forms)
            return self.form
        chooser = self.chooser
        if chooser is None:
            chooser = self.chooser = FormChooser(raster_segment.form_for(self.ctx, self.forms), forms=self.forms)
            name = scan_form_memory.key(self.ctx, self.name, key, sizes)
            kept = scan_form_memory.recall(name, self.forms)
            if kept is not None:
                chooser.settle(key, sizes, *kept)
            self._kept = (name, None if kept is None else kept[0])
            self._decided = chooser.probes
        timer, pending = self.timer, self._pending
        if self._open is not None:   # the last frame raised before end(): its time is lost
            slot, ticket = self._open
            self._open = None
            timer.stop(slot)
            pending.append((slot, None))
            chooser.record(ticket, None)
        while pending and timer.ready(pending[0][0]):   # results in issue order; never waits
            slot, ticket = pending.popleft()
            ms = timer.read(slot)
            if ticket is not None:
                chooser.record(ticket, ms)
        if chooser.probes != self._decided:   # a probe decided: kept for the next run
            self._decided = chooser.probes
            self._keep(chooser)
        form, ticket = chooser.next(key, sizes, timer.free())
        self.form = form
        gl_replay.each_frame(self._quiet_next, chooser.skip)   # a frame played instead of drawn counts here too
        if ticket is not None:
            slot = timer.start()
            if slot is None:
                chooser.record(ticket, None)
            else:
                self._open = (slot, ticket)
        return form

    def _quiet_next(self) -> bool:
        """Whether the next frame's ``begin`` would read no time and give this form untimed."""
        c = self.chooser
        return (c is not None and not self._pending and self._open is None
                and c.quiet_next(self.timer.free()))

    def _keep(self, chooser: FormChooser) -> None:
        """Keep the chooser's decision on disk under its probe's key (when it is another than the
        one kept there: once a decision, not every re-probe that confirms it)."""
        name = scan_form_memory.key(self.ctx, self.name, *chooser.measured_on)
        if self._kept != (name, chooser.choice):
            scan_form_memory.remember(name, chooser.choice, chooser.medians)
            self._kept = (name, chooser.choice)

    def end(self) -> None:
        if self._open is not None:
            self.timer.stop(self._open[0])
            self._pending.append(self._open)
            self._open = None

    def stats(self) -> dict:
        c = self.chooser if self.tuning() else None
        out = {"form": FORM_NAMES[self.current()]}
        if c is not None:
            out["probing"] = c.probing
            out["probes"] = c.probes
            out["recalled"] = c.recalled
            out["ms"] = {FORM_NAMES[f]: (None if c.medians[f] is None else round(c.medians[f], 4))
                         for f in range(c.forms)}
        return out

    def release(self) -> None:
        if self.timer is not None and hasattr(self.timer, "release"):
            self.timer.release()
        self.timer, self.chooser, self._timer_ok, self._open = None, None, None, None
        self._kept, self._decided = None, 0
        self._pending.clear()


class ScanForms:
    """The renderer's sites (``hair``, ``dom_z0``, ``dom``)."""

    def __init__(self, ctx):
        for name in SITES:
            setattr(self, name, ScanFormSite(ctx, name))

    def by(self) -> str:
        """Who picks the forms now: "forced" (FORCED), "tuner" or "fixed" (balance_for's rule)."""
        if raster_segment.FORCED is not None:
            return "forced"
        return "tuner" if self.hair.tuning() else "fixed"

    def probing(self) -> bool:
        """Whether a site's tuner is still timing its forms (its first frames, or after a change)."""
        sites = [getattr(self, name) for name in SITES]
        return any(s.tuning() and s.chooser is not None and s.chooser.probing for s in sites)

    def stats(self) -> dict:
        """{"hair": "tiled", "dom_z0": "per_thread", "dom": "balanced"}: each site's form now."""
        return {name: FORM_NAMES[getattr(self, name).current()] for name in SITES}

    def details(self) -> dict:
        """Per site: its form, and with the tuner its last probe's medians (ms) and probe count."""
        return {name: getattr(self, name).stats() for name in SITES}

    def release(self) -> None:
        for name in SITES:
            getattr(self, name).release()
