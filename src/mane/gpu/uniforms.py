"""Uniform writes that skip the GL call when the bytes have not changed since the last write.

Most of a frame's uniforms (the settings' constants, texture units, the lights) hold the same
value from one frame to the next; a program keeps its uniforms, so writing them again only
costs the CPU (moderngl's Python setter, then the driver). ``write_uniform`` packs the value
as moderngl's ``Uniform.value`` setter does, remembers the bytes on the uniform object and
writes only when they differ. The remembered bytes are only right if every write to that
uniform goes through here: code that sets uniforms of mane's render programs must not use
``prog[name].value = ...``, ``prog[name] = ...`` or ``prog[name].write(...)`` directly
(tests/test_render_frame_cache.py checks ``mane.render``).
"""
from __future__ import annotations

import struct

LAST_SENT = _LAST = "_mane_sent"   # on a uniform: the value object it was last written
_PLAIN = (int, float, bool, tuple, list, bytes)


def uniform_bytes(uniform, value) -> bytes:
    """``value`` packed as moderngl's ``Uniform.value`` setter packs it (bytes pass through)."""
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    fmt = uniform.fmt
    if uniform.array_length > 1:
        if uniform.dimension > 1:
            return b"".join(struct.pack(fmt, *row) for row in value)
        return b"".join(struct.pack(fmt, item) for item in value)
    if uniform.dimension > 1:
        return struct.pack(fmt, *value)
    return struct.pack(fmt, value)


def write_uniform(uniform, value) -> None:
    """Write ``value`` (a moderngl uniform value: a number, a tuple, a list of them, or the
    bytes) unless the uniform was last written the same value (an equal number of the same
    type, an equal tuple; 0.0 and -0.0 count as equal)."""
    sent = uniform.__dict__
    last = sent.get(_LAST)
    if last is not None and last.__class__ is value.__class__ and last == value:
        return
    uniform.write(uniform_bytes(uniform, value))
    sent[_LAST] = value if value.__class__ in _PLAIN else None
    writes = sent.get(_WRITES)
    if writes is not None:
        writes[0] += 1


def forget_uniforms(program) -> None:
    """Forget what was written to ``program``'s uniforms (after something wrote them directly)."""
    for member in getattr(program, "_members", {}).values():
        member.__dict__.pop(_LAST, None)
        writes = member.__dict__.get(_WRITES)
        if writes is not None:
            writes[0] += 1


_PLANS = "_mane_plans"   # on a program: id(values dict) -> [the dict, ((uniform, its __dict__, packed value), ...),
                         # the program's write count when the dict was last set whole]; and the dict's
                         # names (a tuple) -> their uniforms (None where the program has none)
_WRITES = "_mane_writes"   # on a program, and on each uniform of its plans: the program's write count, [n]
MAX_PLANS = 64


def set_uniforms(prog, values: dict, pack=None) -> None:
    """Write every uniform of ``values`` (name -> value; a dict not changed once made) that
    ``prog`` has. The program's uniforms of the dict and their values (``pack(uniform, value)``
    where given) are found once per (program, dict) and kept on the program; a uniform whose
    last write was that very value object (write_uniform remembers it) is not looked at again,
    and the whole dict is not looked at again while no uniform of the program's plans has
    been written (write_uniform counts the writes) since it was last set."""
    d = prog.__dict__
    plans = d.get(_PLANS)
    if plans is None:
        plans = d[_PLANS] = {}
        d[_WRITES] = [0]
    writes = d[_WRITES]
    entry = plans.get(id(values))
    if entry is None or entry[0] is not values:
        # a new dict (a moving camera's View makes one a frame): its names' uniforms are found
        # once per (program, names) and only its values packed again
        names = tuple(values)
        found = plans.get(names)
        if found is None:
            found = []
            for name in names:
                u = prog.get(name, None)
                if u is not None:
                    u.__dict__[_WRITES] = writes
                found.append(u)
            found = plans[names] = tuple(found)
        if pack is None:
            pairs = tuple((u, u.__dict__, v) for u, v in zip(found, values.values()) if u is not None)
        else:
            pairs = tuple((u, u.__dict__, pack(u, v)) for u, v in zip(found, values.values()) if u is not None)
        if len(plans) >= MAX_PLANS:
            plans.clear()
            plans[names] = found
        entry = plans[id(values)] = [values, pairs, None]
    elif entry[2] == writes[0]:
        return
    for u, sent, v in entry[1]:
        if sent.get(_LAST) is not v:
            write_uniform(u, v)
    entry[2] = writes[0]
