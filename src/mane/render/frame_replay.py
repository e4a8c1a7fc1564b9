"""A renderer's frames issued again from a recording while nothing they are made of changes.

Issuing the target frame cost the CPU ~0.15 ms of mane's Python on a 2-core CPU machine and
~0.55 ms on the GPU machines' hosts (an H100's host, 2026-12-05, beside 0.46 ms of GL calls):
passes choosing programs, binding buffers and images, setting uniforms. While the camera, the
lights, the settings and the renderer's objects stay, every frame makes the same ~120 GL calls;
a simulator moving the hair changes the buffers' contents, not the calls. So (gpu/replay.py) a
frame is recorded and the recording issued instead of the Python:

1. ``plan(camera, lights, refine)`` before a frame: the frame's key is the camera and the lights
   (by value), the renderer's attributes (by identity: a new setting, groom, head, target or
   instance list is a new object), its strands' attributes, whether the hair moved since the
   last frame (light_key.py reuses the light-space passes while it does not), and the module
   switches that change what a frame issues (``switches``); its phase is which extra light
   extra_shadows.py draws this frame (one in turn), with a recording per phase. Frames drawn
   with a sub-pixel offset (``refine``) or an ``on_pass`` callback are never recorded; a frame
   the profiler times is never played.
2. A frame whose key is the last frame's is drawn while recorded, and its calls are compared
   with its phase's last recording: two recordings of a phase with the same calls,
   nothing read back in them (a fence, a buffer read, a finish, a GL object made or released:
   gpu/replay.py's ``side``), confirm it.
3. The phase's next frame with that key plays the recording, once every per-frame hook
   registered in it (the scan-form tuner's timed frames, the tiled raster's peak check) says
   the frame comes out as recorded; the hooks then move their counters as the frame would have.
   A frame a confirmed recording's hooks say is not quiet is drawn without a recording, and it,
   like a recorded frame that read something back, takes every confirmation away: the next
   recorded frame of each phase must match its recording again (an unconfirmed recording's
   hooks not quiet: the frame is recorded afresh, as the passes that registered them may not
   run in it). A quiet frame the profiler times is drawn and keeps them.

``VERIFY`` (``MANE_REPLAY_VERIFY=1``; the test suite sets it): a frame that would be played is
drawn and recorded instead, and a recording that differs from the confirmed one raises
``ReplayMismatch`` (something a frame depends on is missing from the key). ``REPLAY`` False
(``MANE_REPLAY=0``) draws every frame.
"""
from __future__ import annotations

import os

from . import light_key
from .passes import base, depth_tiles, head_pass, occlusion_tiles, raster_segment, raster_tiles, scan_form
from .passes.extra_shadows import extra_casters

REPLAY = os.environ.get("MANE_REPLAY", "1") != "0"
VERIFY = os.environ.get("MANE_REPLAY_VERIFY", "0") == "1"
# renderer attributes every frame sets (bookkeeping), that count the hair's writes (a simulator
# moves them every frame; the key has whether the hair moved instead), and the head's box last
# cleared in the depth target (made again every frame from the view and the target)
PER_FRAME = frozenset({"frames_rendered", "last_frame", "_still", "_replay", "_geometry_version", "_sim_rebuilds",
                       "_strand_writes", "_hdr_resolved", "sample_offsets", "_depth_written"})


class ReplayMismatch(AssertionError):
    """A frame drawn under VERIFY issued other calls than the recording that would have stood in."""


def switches() -> tuple:
    """The module switches benchmarks and tests set that change a frame's calls."""
    return (light_key.KEEP, raster_segment.FORCED, raster_segment.SUBGROUP_SCAN, scan_form.TUNE,
            scan_form.WATCH, scan_form.REPROBE, depth_tiles.HEAD_CULL, occlusion_tiles.HAIR_CULL,
            occlusion_tiles.SPLIT, head_pass.SHADE_BY_COMPUTE, base.SKIN_BOUNCE_GRID, raster_tiles.CAPACITY,
            raster_tiles.CHECK_EVERY)


class _Take:
    """A phase's recording: the calls, the Frame they drew, the renderer's _hdr_resolved after
    them, and whether the frame after it issued the same calls (confirmed)."""

    def __init__(self, rec, frame, resolved: bool):
        self.rec, self.frame, self.resolved, self.confirmed = rec, frame, resolved, False
        self.calls = None   # what is played: the recording without its redundant binds (Recording.pruned)


class FrameReplay:
    """One renderer's recordings (one per phase: the extra light whose maps the frame draws) and
    the key they stand for."""

    def __init__(self, renderer):
        self.renderer = renderer
        self._view = None        # (camera, lights) of the last frame
        self._hair = None        # the hair's version at the last frame
        self.key = None          # the recordings' key
        self.takes: dict = {}    # phase -> _Take
        self._alive = None       # the objects whose identities the key holds (kept: no identity reused)
        self.played = 0          # frames played (Renderer.stats: frames_replayed)

    def key_of(self, camera, lights, moved: bool) -> tuple:
        """The frame's key, and the objects it holds by identity."""
        r = self.renderer
        objects = [v for k, v in r.__dict__.items() if k not in PER_FRAME]
        if r.strands is not None:
            objects += r.strands.__dict__.values()
        return (camera, lights, moved, tuple(map(id, objects)), switches()), objects

    def plan(self, camera, lights: tuple, refine: bool):
        """("play", phase), ("record", phase), ("verify", phase: VERIFY's frame that would have
        been played), ("timed", None: the profiler times a frame that would have been played: it
        is drawn, the recordings stay confirmed) or ("draw", None: drawn, the confirmations
        dropped) for this frame."""
        r = self.renderer
        hair = r.hair_version()
        moved, self._hair = hair != self._hair, hair
        view, self._view = self._view, (camera, lights)
        if not REPLAY or refine or r.on_pass is not None or view is None or view != self._view:
            self.forget(keep_view=True)
            return "draw", None
        key, objects = self.key_of(camera, lights, moved)
        if key != self.key:   # recorded from the second frame with this key on: a key
            self.takes.clear()          # that changes every frame (a nodding head) costs no recording
            self.key, self._alive = key, objects
            return "draw", None
        # extra_shadows.py draws one extra light's maps a frame, in turn: a recording per turn
        phase = r.frames_rendered % max(1, len(extra_casters(r.settings, lights)))
        take = self.takes.get(phase)
        if take is None:
            return "record", phase
        if not take.rec.ready():   # the tuner times or reads, the tiled raster checks
            if take.confirmed:
                return "draw", None   # drawn as it comes, without a recording's cost
            del self.takes[phase]     # a recording whose hooks ran in another frame than this one may
            return "record", phase    # (a light-space pass since reused): recorded afresh
        if take.confirmed:
            if r.profiler.quiet():
                return ("verify" if VERIFY else "play"), phase
            return "timed", None   # drawn with the profiler's sections; what it changes a played frame would
        return "record", phase

    def play(self, phase: int):
        """Issue the phase's confirmed recording; the Frame it drew (the caller re-dates it)."""
        take = self.takes[phase]
        take.rec.advance()
        if take.calls is None:
            take.calls = take.rec.pruned()
        take.calls.play()
        self.played += 1
        return take

    def recorded(self, phase: int, rec, frame, verify: bool = False) -> None:
        """A frame drawn under the recorder ``rec`` in ``phase``; ``verify``: one the phase's
        confirmed recording would have stood in for (VERIFY)."""
        take = self.takes.get(phase)
        if rec.side is not None:
            diff = f"it read {rec.side}"
        else:
            diff = rec.difference(take.rec) if take is not None else "no recording of this phase"
        if diff is None:
            take.confirmed = True
            take.rec.hooks, take.frame, take.resolved = rec.hooks, frame, self.renderer._hdr_resolved
            take.calls = None
            return
        if verify:
            self.forget(keep_view=True)
            raise ReplayMismatch(f"a frame the recording would have stood in for came out otherwise ({diff}): "
                                 "something the frame depends on is missing from frame_replay's key")
        if rec.side is not None:
            self.drawn()   # its state may have moved with what it read: recorded frames must match again
            return
        self.takes[phase] = _Take(rec, frame, self.renderer._hdr_resolved)

    def drawn(self) -> None:
        """A frame drawn otherwise: every recording must be confirmed again."""
        for take in self.takes.values():
            take.confirmed = False

    def forget(self, keep_view: bool = False) -> None:
        self.takes.clear()
        self.key = self._alive = None
        if not keep_view:
            self._view = None
