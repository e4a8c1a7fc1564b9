"""The dtype of a data set's strand and guide id maps: the smallest unsigned type that holds
every id and keeps its largest value for "no hair" (uint8 up to 255 ids, uint16 up to 65,535,
else uint32), chosen per sample from its groom's rendered strands and guides.

    id_dtype(50_000)          # numpy.uint16: ids 0..49,999, no hair = 0xFFFF
    ids(strand_map, 50_000)   # the renderer's uint32 map (0xFFFFFFFF: none) in that dtype
"""
from __future__ import annotations

import numpy as np

ID_DTYPES = (np.uint8, np.uint16, np.uint32)


def id_dtype(count: int) -> type:
    """The smallest unsigned dtype for ids 0..count-1 that keeps its largest value free for "no
    hair" (uint16 up to 65,535 strands: ids 0..65,534, none = 0xFFFF)."""
    for t in ID_DTYPES:
        if count <= np.iinfo(t).max:
            return t
    raise ValueError(f"{count} ids do not fit in uint32 with a value left for no hair")


def ids(a: np.ndarray, count: int) -> np.ndarray:
    """A uint32 id map (0xFFFFFFFF: none) in id_dtype(count): ids below count keep their value
    and 0xFFFFFFFF wraps to the smaller type's maximum (C's unsigned conversion)."""
    return a.astype(id_dtype(count), copy=False)
