"""What a hair file says about its look (colour, width, opacity), as RenderSettings changes.

mane renders guide strands multiplied into clumps with one hair material, so a file's per-point
colours, widths and transparency drive the render through their typical values: the mean
colour becomes ``hair_color``, the median root width ``width`` (and the median tip/root ratio
``width_tip``), the mean opacity ``oit_opacity`` (used by the OIT methods). The renderer does
this for grooms read from a file (``mane.load`` records ``metadata['frame']``): procedural
grooms carry their style's widths and colours but render with the scene's look. Only values that
came from the file count: a cyHair header default left at the format's reference value
(colour (1, 1, 1), thickness 1) is not a colour or a width, and a width outside 5 um..2 mm
(after the groom's units were turned into metres) is not a hair's. ``RenderSettings.
use_file_colors`` (``--file-colors/--no-file-colors``) turns this off: the scene's hair model
then decides. Per-strand variation is not rendered (the mean stands for all strands).
"""
from __future__ import annotations

import numpy as np

WIDTH_RANGE = (5e-6, 2e-3)
_CYHAIR_REFERENCE = {"colors": ("color", [1.0, 1.0, 1.0]), "thickness": ("thickness", 1.0),
                     "transparency": ("transparency", 0.0)}


def _from_file(groom, name: str) -> bool:
    cy = groom.metadata.get("cyhair")
    if isinstance(cy, dict) and name in cy.get("defaults_used", []):
        key, ref = _CYHAIR_REFERENCE[name]
        return cy.get("defaults", {}).get(key) != ref
    return True


def file_appearance(groom) -> dict:
    """RenderSettings fields the groom's own arrays ask for (empty when it carries none)."""
    out = {}
    if groom.colors is not None and _from_file(groom, "colors"):
        c = np.clip(groom.colors.astype(np.float64).mean(axis=0), 0.0, 1.0)
        out["hair_color"] = tuple(float(x) for x in c)
    if groom.widths is not None and _from_file(groom, "thickness"):
        roots = groom.widths[groom.offsets[:-1]].astype(np.float64)
        tips = groom.widths[groom.offsets[1:] - 1].astype(np.float64)
        w = float(np.median(roots))
        if WIDTH_RANGE[0] <= w <= WIDTH_RANGE[1]:
            out["width"] = w
            ratio = float(np.median(tips / np.maximum(roots, 1e-12)))
            out["width_tip"] = float(np.clip(ratio, 0.05, 1.0))
    if groom.transparency is not None and _from_file(groom, "transparency"):
        opacity = float(1.0 - np.clip(groom.transparency, 0.0, 1.0).mean())
        if opacity < 1.0:
            out["oit_opacity"] = max(opacity, 0.01)
    return out
