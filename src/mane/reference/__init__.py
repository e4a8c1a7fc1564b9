"""An offline ground truth: the real-time renderer's scene path traced by Mitsuba 3.

    from mane import reference
    img = reference.render(groom, head=mesh, settings=s, camera=cam, lights=lights, spp=256)
    reference.save_png(img, "ref.png")                   # linear -> sRGB, no tone curve
    strands = reference.expanded_strands(groom, s)       # what the GPU expand pass draws
    mat = reference.HairMaterial.from_settings(s)        # Chiang 2016 parameters of s

Mitsuba's variant: ``variant=`` or ``$MANE_REFERENCE_VARIANT`` (scalar_rgb; cuda_ad_rgb on an
NVIDIA GPU). Samples above a pass (64; 512 for the GPU) are rendered as independent passes in child processes and averaged
(passes.py): a Mitsuba crash fails one pass (retried with another seed), not the caller.
Needs the optional extra ``pip install mane[reference]`` (Mitsuba 3.9, FLIP); without it
``render`` raises ``ReferenceUnavailableError`` (a ManeError) saying so. See render.py for
what is drawn and the units, scene.py for the curves and the material mapping.
(mane.twins is something else: the NumPy twins of the GPU kernels.)
"""
from __future__ import annotations

from .scene import (ExpandedStrands, HairMaterial, beta_m_to_lobe_width, bspline_control_points, bspline_eval,
                    expanded_strands, lobe_width_to_beta_m, renderer_strands)
from .passes import DEFAULT_PASS_SPP, ReferencePassError
from .render import (INSTALL_HINT, MITSUBA_VARIANT, VARIANT_ENV, VARIANTS, ReferenceUnavailableError, available,
                     cache_key, default_pass_spp, hair_coverage, mitsuba, render, render_png, resolve_variant,
                     save_png, to_srgb8)

__all__ = [
    "render", "render_png", "save_png", "hair_coverage", "cache_key", "available", "mitsuba", "to_srgb8",
    "ExpandedStrands", "HairMaterial", "expanded_strands", "renderer_strands", "bspline_control_points",
    "bspline_eval", "lobe_width_to_beta_m", "beta_m_to_lobe_width", "ReferenceUnavailableError",
    "MITSUBA_VARIANT", "VARIANTS", "VARIANT_ENV", "resolve_variant", "default_pass_spp", "INSTALL_HINT",
    "ReferencePassError", "DEFAULT_PASS_SPP",
]
