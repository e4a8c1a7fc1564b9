"""What the light-space passes' targets are made of, so that a frame can reuse them.

The shadow map, the deep opacity maps (light 0's and the extra lights'), the opacity maps,
ADSM, the density grid and the skin's bounce (``Pass.light_space``) are drawn from the lights'
views: they depend on the lights, the hair, the head and the settings, not on the camera. While
none of those changes (a still groom seen from an orbiting camera, the frames of a still
picture) a frame reuses the targets the pass made last instead of drawing them again. The key holds:

- by identity: the settings object, the strands, the head's buffers (new at every set_head, even
  of the same mesh), the instances, light 0's view and the extra lights' views (the renderer
  keeps one view object per light and scene box);
- by value: the lights, the hair's depth ranges along them, the hair's version
  (``Renderer.hair_version``: new frames, ``strands_changed`` calls, a simulator's steps; the
  still picture's notion of the hair moving, so a paused simulation's frames reuse them), the
  head's transform and what of the rendered strands follows the camera
  (``ExpandPass.camera_key``: the strands the coverage LOD keeps, with the distance LOD the eye).

A light whose fields cannot be hashed (arrays) makes no key: its frames draw every pass, as
every frame does while ``KEEP`` is False (tests of a pass's own work from frame to frame, such as
the scan-form tuner's timings of the deep opacity dispatches).
"""
from __future__ import annotations

KEEP = True


class LightKey:
    """``same``: objects compared by identity; ``equal``: values compared with ==."""

    __slots__ = ("same", "equal")

    def __init__(self, same: tuple, equal: tuple):
        self.same, self.equal = same, equal

    def matches(self, other: "LightKey | None") -> bool:
        if other is None or len(other.same) != len(self.same):
            return False
        return all(a is b for a, b in zip(self.same, other.same)) and self.equal == other.equal


def light_key(renderer, frame) -> LightKey | None:
    """The key of ``frame``'s light-space targets (None: not to be kept)."""
    if not KEEP:
        return None
    try:
        lights = tuple(frame.lights)
        hash(lights)
    except TypeError:
        return None
    r = renderer
    s, st = r.settings, r.strands
    views = tuple(v for v, _ in frame.shadow_views)
    same = (s, st, r.head_buffers(), r.instances, frame.light_view, *views)
    drawn = r.get_pass("expand").camera_key() if st is not None else None
    equal = (lights, frame.hair_depth_range, tuple(d for _, d in frame.shadow_views), r.hair_version(),
             r.head_model()[0] if r.head is not None else None, drawn)
    return LightKey(same, equal)
