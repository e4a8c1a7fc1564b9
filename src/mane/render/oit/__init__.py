"""Order-independent transparency for the hair (``RenderSettings.oit``; ``mane render --oit NAME``).

    r = Renderer(RenderSettings(oit="dbk_buffer", oit_opacity=0.6))
    r.render(); r.stats()["oit_bytes"]

Methods, one module each: ``sorted_blending``, ``random_subsets``, ``a_buffer``,
``k_buffer``, ``dbk_buffer``, ``shortcut`` (see ``base.OitMethod`` for the interface). Where the
renderer uses the compute rasteriser (``settings.rasterizer``), the A-buffer, K-buffer,
DBK-buffer and ShortCut run on compute shaders instead of triangles (``compute.py``).
"""
from __future__ import annotations

import importlib

METHOD_MODULES = {
    "sorted_blending": ("sorted_blending", "SortedBlending"),
    "random_subsets": ("random_subsets", "RandomSubsets"),
    "a_buffer": ("a_buffer", "ABuffer"),
    "k_buffer": ("k_buffer", "KBuffer"),
    "dbk_buffer": ("dbk_buffer", "DBKBuffer"),
    "shortcut": ("shortcut", "ShortCut"),
}
METHODS = tuple(METHOD_MODULES)
LABELS = {"none": "none (depth-tested blending)", "sorted_blending": "sorted blending",
          "random_subsets": "random subsets", "a_buffer": "A-buffer", "k_buffer": "K-buffer",
          "dbk_buffer": "DBK-buffer", "shortcut": "ShortCut"}


def method_class(name: str):
    if name not in METHOD_MODULES:
        from ...errors import UsageError

        raise UsageError(f"unknown OIT method {name!r}; one of {', '.join(METHODS)}")
    module, cls = METHOD_MODULES[name]
    return getattr(importlib.import_module(f"{__name__}.{module}"), cls)


def make_method(name: str, renderer):
    """The method object: its compute-rasteriser form (``compute.py``) where the renderer draws
    the hair with compute shaders (``compute.uses_compute``), else the hardware one."""
    from .compute import compute_class

    cls = compute_class(name, renderer) if name in METHOD_MODULES else None
    return (cls or method_class(name))(renderer)


__all__ = ["METHODS", "LABELS", "method_class", "make_method"]
