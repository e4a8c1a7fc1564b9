"""Per-pass GPU timings without stalling the pipeline.

    prof = GpuProfiler(ctx)
    for frame in frames:
        with prof.section("simulate"):
            sim.step(state, dt)
        with prof.section("render"):
            with prof.section("shading"):      # sections nest
                ...
        prof.frame()
    prof.means()        # {"simulate": 1.9, "render": 4.2, "shading": 3.1}   (milliseconds)
    print(prof.summary())

Two sources, ``prof.source`` says which:

``"gpu-timer"``
    Each section is a pair of ``GL_TIMESTAMP`` queries (``glQueryCounter``) issued into the
    command stream; results are read later, only once ``GL_QUERY_RESULT_AVAILABLE`` says
    they are there, so the CPU never waits for the GPU. Timestamps (unlike
    ``GL_TIME_ELAPSED``, which moderngl's ``ctx.query(time=True)`` uses) may nest, so a
    section inside another is timed on the GPU too. moderngl's Query cannot poll for
    availability (reading ``.elapsed`` blocks), so the queries are raw GL through ctypes.
    Each name keeps a small pool of query pairs; only if the GPU falls ``pool_size``
    sections of one name behind does the profiler wait for the oldest.

``"cpu"``
    ``ctx.finish()`` before and after, then ``perf_counter``: exact, but it drains the
    pipeline at every section boundary. Used where timer queries are missing, where the GL
    entry points cannot be loaded, and on software renderers, where they are unreliable:
    on Mesa llvmpipe ``GL_TIME_ELAPSED`` around a 150 ms compute dispatch reads 1 ns, and
    around a 700 ms draw reads 4294.97 ms (2^32 ns); timestamps around a draw give 4 ms,
    because llvmpipe rasterises at the flush. ``prof.reason`` says why the CPU was chosen.
"""
from __future__ import annotations

import ctypes
import time
from collections import OrderedDict, deque
from contextlib import contextmanager, nullcontext

from ..errors import UsageError

_OFF = nullcontext()   # a disabled profiler's section (nullcontext is reusable)

GL_TIMESTAMP = 0x8E28
GL_QUERY_RESULT = 0x8866
GL_QUERY_RESULT_AVAILABLE = 0x8867

SOURCES = ("gpu-timer", "cpu")
EVERY = 4   # a profiler times one frame in this many by default (a timed one costs the CPU's issue)


class TimestampQueries:
    """Raw GL query objects, for glQueryCounter(GL_TIMESTAMP) pairs (the profiler's and the scan-form
    tuner's, render/passes/scan_form.py)."""

    def __init__(self, ctx):
        from .capabilities import gl_function

        u32p = ctypes.POINTER(ctypes.c_uint)
        self.gen = gl_function(ctx, "glGenQueries", None, ctypes.c_int, u32p)
        self.delete = gl_function(ctx, "glDeleteQueries", None, ctypes.c_int, u32p)
        self.counter = gl_function(ctx, "glQueryCounter", None, ctypes.c_uint, ctypes.c_uint)
        self.get_iv = gl_function(ctx, "glGetQueryObjectiv", None, ctypes.c_uint, ctypes.c_uint,
                                  ctypes.POINTER(ctypes.c_int))
        self.get_u64 = gl_function(ctx, "glGetQueryObjectui64v", None, ctypes.c_uint, ctypes.c_uint,
                                   ctypes.POINTER(ctypes.c_uint64))
        self.flush = gl_function(ctx, "glFlush", None)
        self.ok = all(f is not None for f in (self.gen, self.delete, self.counter, self.get_iv, self.get_u64,
                                              self.flush))

    def new_pair(self) -> tuple[int, int]:
        ids = (ctypes.c_uint * 2)()
        self.gen(2, ids)
        if not ids[0] or not ids[1]:
            raise RuntimeError("glGenQueries returned no query objects")
        return int(ids[0]), int(ids[1])

    def release(self, pairs) -> None:
        flat = [q for pair in pairs for q in pair]
        if flat:
            arr = (ctypes.c_uint * len(flat))(*flat)
            try:
                self.delete(len(flat), arr)
            except Exception:
                pass

    # Neither stamps nor reads are in a recorded frame's calls (gpu/replay.py): a played frame is
    # not timed, and what a read decides (the scan-form tuner's form) shows in that frame's calls
    def stamp(self, query: int) -> None:
        self.counter(query, GL_TIMESTAMP)

    def available(self, query: int) -> bool:
        v = ctypes.c_int(0)
        self.get_iv(query, GL_QUERY_RESULT_AVAILABLE, ctypes.byref(v))
        return bool(v.value)

    def result(self, query: int) -> int:  # blocks until the result is there
        v = ctypes.c_uint64(0)
        self.get_u64(query, GL_QUERY_RESULT, ctypes.byref(v))
        return int(v.value)


def profile_every(profile) -> int | None:
    """A ``profile`` argument (Renderer, Simulator) as the profiler's ``every``: False -> 0 (off),
    True -> None (the profiler's default, EVERY), a whole number N >= 1 -> N (every Nth frame)."""
    if isinstance(profile, bool):
        return None if profile else 0
    if isinstance(profile, int) and profile >= 0:
        return profile
    raise UsageError(f"profile must be True, False or a whole number of frames >= 1 (time every Nth), "
                     f"not {profile!r}")


class GpuProfiler:
    """Times named sections (passes) on the GPU, or on the CPU where GPU timing is unreliable.

    ``source``: ``None`` picks (GPU timer queries on hardware, the CPU on software
    renderers); ``"gpu-timer"`` or ``"cpu"`` forces one. ``history``: samples kept per
    name (a moving window; ``means`` averages it). ``pool_size``: query pairs in flight per name.
    ``every``: time the sections of every ``every``-th frame only (frames counted by ``frame()``,
    the first one timed); None: EVERY. The CPU source drains the pipeline at every section, and
    on one H200 machine a timed frame of the renderer's took the CPU 0.29-0.54 ms more to issue
    (within the noise on another), so by default one frame in four is timed
    (docs/performance.md, "The profiler's cost, and its timings").
    """

    def __init__(self, ctx, enabled: bool = True, *, source: str | None = None,
                 history: int = 600, pool_size: int = 8, every: int | None = None):
        if source is not None and source not in SOURCES:
            raise UsageError(f"profiler source must be one of {SOURCES}, not {source!r}")
        if every is not None and (isinstance(every, bool) or not isinstance(every, int) or every < 1):
            raise UsageError(f"profiler 'every' must be a whole number of frames >= 1, not {every!r}")
        self.ctx = ctx
        self.enabled = bool(enabled)
        self.history = int(history)
        self.pool_size = max(1, int(pool_size))
        self._samples: "OrderedDict[str, deque]" = OrderedDict()
        self._depth: dict[str, int] = {}      # name -> nesting depth when first seen (for summary)
        self._stack: list[str] = []
        self._frames = 0
        self._frame_start: float | None = None
        self._frame_ms: deque = deque(maxlen=self.history)
        self._queries: TimestampQueries | None = None
        self._free: dict[str, list[tuple[int, int]]] = {}
        self._pending: "deque[tuple[str, tuple[int, int]]]" = deque()
        self._pending_per_name: dict[str, int] = {}
        self.source, self.reason = self._choose(source)
        self.every = EVERY if every is None else every

    # ------------------------------------------------------------------ choosing a source
    def _choose(self, forced: str | None) -> tuple[str, str]:
        if forced == "cpu":
            return "cpu", "asked for"
        try:
            from .capabilities import get_capabilities

            caps = get_capabilities(self.ctx)
        except Exception as exc:  # no caps: try the queries anyway
            caps, note = None, f"capabilities unavailable ({exc})"
        else:
            note = ""
        if forced is None and caps is not None:
            if caps.is_software:
                return "cpu", (f"software renderer ({caps.renderer}): its timer queries are unreliable "
                               "(~1 ns around compute)")
            if caps.version_code < 330 and "GL_ARB_timer_query" not in caps.extensions:
                return "cpu", "no timer queries (GL_ARB_timer_query)"
        try:
            queries = TimestampQueries(self.ctx)
        except Exception as exc:  # pragma: no cover - ctypes trouble
            return "cpu", f"cannot load GL query functions ({exc})"
        if not queries.ok:
            return "cpu", "cannot load the GL query functions (glQueryCounter, glGetQueryObjectui64v)"
        self._queries = queries
        return "gpu-timer", note or ("asked for" if forced else "GL_TIMESTAMP queries")

    # ------------------------------------------------------------------ sections
    def quiet(self) -> bool:
        """Whether the next frame's sections are off (no timer query, no CPU finish)."""
        return not self.enabled or self._frames % self.every != 0

    def section(self, name: str):
        """Time the GL work issued inside the block under ``name``. Sections may nest. Off, one
        shared do-nothing context (a frame enters a dozen: no generator made for each)."""
        if not self.enabled or self._frames % self.every:
            return _OFF
        return self._timed(name)

    @contextmanager
    def _timed(self, name: str):
        name = str(name)
        self._depth.setdefault(name, len(self._stack))
        self._samples.setdefault(name, deque(maxlen=self.history))
        if name in self._stack:
            raise UsageError(f"profiler section {name!r} is already open (recursive sections of one "
                             f"name cannot be told apart); open: {' > '.join(self._stack)}")
        self._stack.append(name)
        try:
            if self.source == "cpu":
                self.ctx.finish()
                t0 = time.perf_counter()
                yield
                self.ctx.finish()
                self._samples[name].append((time.perf_counter() - t0) * 1e3)
            else:
                pair = self._take_pair(name)
                self._queries.stamp(pair[0])
                try:
                    yield
                finally:
                    self._queries.stamp(pair[1])
                    # to the GPU now: the next section's first stamp then travels with its work. Held
                    # back, a section's stamps can straddle two submissions and time the GPU's wait
                    # for the CPU (H200, the target frame: skin_bounce 0.95 ms against 0.15)
                    self._queries.flush()
                    self._pending.append((name, pair))
                    self._pending_per_name[name] = self._pending_per_name.get(name, 0) + 1
        finally:
            self._stack.pop()

    def _take_pair(self, name: str) -> tuple[int, int]:
        free = self._free.setdefault(name, [])
        if not free:
            if self._pending_per_name.get(name, 0) >= self.pool_size:
                self._wait_oldest(name)  # the GPU is pool_size sections behind: wait for one
            if not free:
                free.append(self._queries.new_pair())
        return free.pop()

    def _wait_oldest(self, name: str) -> None:
        for i, (n, pair) in enumerate(self._pending):
            if n == name:
                del self._pending[i]
                self._record(n, pair)
                return

    def _record(self, name: str, pair: tuple[int, int]) -> None:
        q = self._queries
        t0, t1 = q.result(pair[0]), q.result(pair[1])
        self._pending_per_name[name] -= 1
        self._free.setdefault(name, []).append(pair)
        if name in self._samples:  # not reset since
            self._samples[name].append(max(0, t1 - t0) / 1e6)

    def collect(self, wait: bool = False) -> None:
        """Read the results that are ready (all of them, waiting, with ``wait``). The GPU writes
        timestamps in the order they were issued, and ``_pending`` holds the sections in the order
        of their closing stamps: the first one not ready ends the look (one availability query a
        frame while the GPU is behind, not one a section)."""
        if self._queries is None:
            return
        while self._pending:
            name, pair = self._pending[0]
            if not wait and not self._queries.available(pair[1]):
                return
            self._pending.popleft()
            self._record(name, pair)

    def flush(self) -> None:
        """Wait for every issued section's result."""
        self.collect(wait=True)

    def frame(self) -> None:
        """Mark the end of a frame: gather finished results and record the frame's wall time."""
        now = time.perf_counter()
        if self._frame_start is not None:
            self._frame_ms.append((now - self._frame_start) * 1e3)
        self._frame_start = now
        self._frames += 1
        self.collect()

    # ------------------------------------------------------------------ results
    @property
    def frames(self) -> int:
        return self._frames

    def names(self) -> list[str]:
        return list(self._samples)

    def samples(self, name: str, wait: bool = False) -> list[float]:
        """The kept samples of ``name``, in milliseconds, oldest first."""
        self.collect(wait)
        return list(self._samples.get(name, ()))

    def means(self, wait: bool = False) -> dict[str, float]:
        """name -> mean milliseconds over the kept samples (names with none are left out).

        GPU results arrive a frame or two late; ``wait=True`` waits for all of them."""
        self.collect(wait)
        return {n: sum(s) / len(s) for n, s in self._samples.items() if s}

    def frame_ms(self) -> float | None:
        """Mean wall-clock milliseconds between ``frame()`` calls, or None before two."""
        return sum(self._frame_ms) / len(self._frame_ms) if self._frame_ms else None

    def reset(self) -> None:
        """Forget every sample and frame time (queries in flight are recycled, not recorded)."""
        if self._queries is not None:
            self.collect(wait=True)
        self._samples.clear()
        self._depth.clear()
        self._frame_ms.clear()
        self._frames = 0
        self._frame_start = None

    def summary(self) -> str:
        """An aligned table: section, samples, mean, min, max (ms); nested sections indented."""
        self.collect(wait=True)
        rows = []
        for name, s in self._samples.items():
            if not s:
                continue
            vals = list(s)
            label = "  " * self._depth.get(name, 0) + name
            rows.append((label, len(vals), sum(vals) / len(vals), min(vals), max(vals)))
        head = f"GPU timings ({self.source}" + (f": {self.reason}" if self.source == "cpu" else "") + ")"
        if not rows:
            return head + "\n  (no samples)"
        fm = self.frame_ms()
        w = max(7, max(len(r[0]) for r in rows), len("frame (wall)") if fm is not None else 0)
        lines = [head, f"  {'section':<{w}}  {'n':>5}  {'mean ms':>9}  {'min ms':>9}  {'max ms':>9}"]
        for label, n, mean, lo, hi in rows:
            lines.append(f"  {label:<{w}}  {n:>5}  {mean:>9.3f}  {lo:>9.3f}  {hi:>9.3f}")
        if fm is not None:
            lines.append(f"  {'frame (wall)':<{w}}  {len(self._frame_ms):>5}  {fm:>9.3f}")
        return "\n".join(lines)

    def release(self) -> None:
        """Delete the GL query objects (the profiler can no longer time on the GPU)."""
        if self._queries is not None:
            self.collect(wait=True)
            self._queries.release([p for pairs in self._free.values() for p in pairs])
            self._free.clear()
        self.enabled = False
