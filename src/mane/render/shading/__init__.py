"""Hair shading models: GLSL in ``hair_shading.glsl``, settings and lookup textures here.

GLSL interface (``#include "shading/hair_shading.glsl"`` from ``src/mane/render/``)::

    struct HairMaterial { vec3 color; float specular; vec3 sigma_a; float roughness;
                          float shift; float eta; float glint; float strand_rand; };
    vec3 hair_bsdf(vec3 T, vec3 V, vec3 L, HairMaterial m);
    vec3 hair_multiple_scattering(vec3 T, vec3 V, vec3 L, HairMaterial m, float transmittance);

T unit tangent root -> tip, V unit direction to the eye, L unit direction to the light.
``hair_bsdf`` includes the cosine / projection factor: radiance_out = hair_bsdf * L_light.
The includer declares ``uniform HairMaterial u_material;`` and sets ``m.strand_rand``
per strand (a per-strand random in [0, 1)); the model is a compile-time define.

Python side::

    s = ShadingSettings(model="marschner", melanin=(1.3, 0.2))
    prog = mane.gpu.program(ctx, vertex=..., fragment=..., defines={**s.defines(), ...})
    s.bind(prog, ctx)            # u_material.* and (LUT model) the lookup textures

Models (``MODELS``): kajiya_kay 0, marschner 1, marschner_lut 2, sadeghi 3,
scheuermann 4, karis 5, chiang 6 (the default: Chiang et al. 2016, the model of pbrt-v4 and
Mitsuba 3's ``hair``, chiang.py / chiang.glsl; bind() binds its ``hair_chiang_n`` table to
unit ``LUT_UNIT_CHIANG``). Multiple scattering (``MULTIPLE_SCATTERING``): none 0, karis 1,
dual 2 (Zinke et al. 2008 dual scattering from tables of this material's fibre lobes,
Chiang's for "chiang", Marschner's otherwise, see dual_scattering.py / dual_scattering.glsl;
bind() binds the ``hair_dual_lut`` texture to unit ``LUT_UNIT_DUAL``); "auto" = dual.

Colour: melanin drives it by default (``melanin``, the brown preset; ``melanin.PRESETS``);
an RGB ``color`` is an explicit opt-in that replaces it. The colour-driven models (Kajiya-Kay,
Sadeghi, Scheuermann, Karis) take from melanin one fibre's colour, Karis's C = exp(-4 sigma_a)
(``melanin.fibre_color``); the fibre models use sigma_a itself and the multiple-scattered volume
colour (Chiang eq. 9) only for the ambient term.

Units: ``roughness`` is the longitudinal width beta_R in radians, ``shift`` the
longitudinal shift alpha_R in radians (Marschner 2003 / Hunz 2016 Table 1: alpha_TT =
-alpha_R/2, alpha_TRT = -3 alpha_R/2, beta_TT = beta_R/2, beta_TRT = 2 beta_R),
``sigma_a`` is per unit fibre radius (see ``melanin``).
"""
from __future__ import annotations

import functools
import math
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from moderngl import InvalidObject

from ...gpu.uniforms import set_uniforms, write_uniform
from ...phases import phase
from ..bindings import (B_HARNESS_RESULTS, B_HARNESS_SAMPLES, TEX_LUT_CHIANG, TEX_LUT_CHIANG_NEAR, TEX_LUT_DUAL,
                        TEX_LUT_M, TEX_LUT_N)
from . import chiang, kajiya_kay, sadeghi, scheuermann
from .melanin import (  # noqa: F401
    MELANIN_MAX,
    PRESETS,
    color_to_sigma_a,
    fibre_color,
    fibre_color_to_sigma_a,
    hair_preset,
    melanin_to_sigma_a,
    sigma_a_to_color,
)

SHADER_DIR = Path(__file__).resolve().parent
HAIR_SHADING_GLSL = SHADER_DIR / "hair_shading.glsl"
HARNESS_COMP = SHADER_DIR / "harness.comp"

MODELS: dict[str, int] = {
    "kajiya_kay": 0,
    "marschner": 1,
    "marschner_lut": 2,
    "sadeghi": 3,
    "scheuermann": 4,
    "karis": 5,
    "chiang": 6,
}
FIBRE_MODELS = ("chiang", "marschner", "marschner_lut")
COLOUR_MODELS = ("kajiya_kay", "sadeghi", "scheuermann", "karis")
MULTIPLE_SCATTERING: dict[str, int] = {"none": 0, "karis": 1, "dual": 2}
# the ranges ShadingSettings accepts (radians for angles); the checks of __post_init__ below
# them say more where a field has a narrower rule (roughness > 0, eta > 1, beta_n > 0)
NUMBER_RANGES = {
    "specular": (0.0, 100.0), "roughness": (0.0, 0.5 * math.pi), "shift": (-0.5 * math.pi, 0.5 * math.pi),
    "eta": (1.0, 10.0), "glint": (0.0, 100.0), "caustic_width": (0.0, math.pi), "caustic_fade": (0.0, 10.0),
    "caustic_limit": (0.0, 1.0), "tt_width": (0.0, math.pi), "glint_width": (0.0, math.pi), "noise": (0.0, 10.0),
    "beta_n": (0.0, 1.0), "dual_density_front": (0.0, 1.0), "dual_density_back": (0.0, 1.0),
    "dual_max_hairs": (0.0, 1e6),
}
TABLE_SIZES = {"chiang_size": (8, 1024), "lut_size": (8, 4096), "dual_size": (8, 4096)}
# the models scaled to Chiang's R albedo: the scale's maker and the GLSL define that carries it
NORMS = {"kajiya_kay": kajiya_kay.specular_norm, "sadeghi": sadeghi.norm, "scheuermann": scheuermann.norm}
NORM_DEFINES = {"kajiya_kay": "HAIR_KK_SPECULAR_NORM", "sadeghi": "HAIR_SADEGHI_NORM",
                "scheuermann": "HAIR_SCHEUERMANN_NORM"}
# the colour-driven models whose colour is made from Chiang's fibre: (sigma_a -> colour, its inverse)
FIBRE_COLOURS = {"kajiya_kay": (kajiya_kay.diffuse_albedo, kajiya_kay.sigma_a_for_albedo),
                 "scheuermann": (scheuermann.color, scheuermann.sigma_a_for_color)}
SIGMA_A_MAX = 1e4      # absorption per unit radius: exp(-1e4) is 0 in any float
COLOR_MAX = 1e3
TABLES = ("exact", "interpolated")

# Texture units bind() uses: the renderer's table (render/bindings.py).
LUT_UNIT_M = TEX_LUT_M
LUT_UNIT_N = TEX_LUT_N
LUT_UNIT_DUAL = TEX_LUT_DUAL
LUT_UNIT_CHIANG = TEX_LUT_CHIANG
LUT_UNIT_CHIANG_NEAR = TEX_LUT_CHIANG_NEAR
TEXTURES_PER_CONTEXT = 16   # of each kind of table


def _glsl_float(x: float) -> str:
    s = repr(float(x))
    if not math.isfinite(float(x)):
        raise ValueError(f"non-finite shading constant {x}")
    return s if any(ch in s for ch in ".e") else s + ".0"


@dataclass(frozen=True)
class ShadingSettings:
    """Hair shading model and material. Colour from ``melanin`` (default) or an RGB ``color``.

    model           one of MODELS (default "chiang")
    color           None, or linear RGB: an explicit opt-in that replaces melanin (``melanin``
                    becomes None). For Kajiya-Kay the fibre's diffuse albedo
                    (kajiya_kay.py), for Scheuermann its diffuse colour (scheuermann.py);
                    for Sadeghi and Karis the fibre colour itself; for the fibre models
                    the multiple-scattered volume colour (sigma_a by Chiang's eq. 9 inversion).
    melanin         (eumelanin, pheomelanin) concentrations (Chiang 2016, 0..8) or a preset's
                    name (melanin.PRESETS); default the "brown" preset; None with no color: brown
    sigma_a         explicit absorption per unit radius (overrides both)
    specular        R-lobe (primary highlight) scale; 1 = physical
    roughness       beta_R, longitudinal width in radians (7.5 deg)
    shift           alpha_R, longitudinal shift in radians (-5 deg)
    eta             index of refraction
    glint           Marschner k_G (Hunz Table 1: 0.5..5; 1 puts the caustic's energy back:
                    TRT integrated over azimuth and theta_o is 0.72-0.95 of Chiang's far-field
                    TRT for brown and blond, against 0.39-0.62 at 0.5; more adds energy) /
                    Sadeghi I_G / Scheuermann sparkle
    caustic_width   Marschner w_c, radians (Table 1: 10..25 deg)
    caustic_fade    Marschner delta eta' (0.2..0.4)
    caustic_limit   Marschner delta h_M (0.5)
    tt_width        Sadeghi azimuthal width of TT (radians)
    glint_width     Sadeghi azimuthal width of the glints (radians)
    noise           Scheuermann tangent-shift noise amplitude (radians) from strand_rand
    energy_clamp    Marschner: the shifted lobes never gain energy (see luts.py)
    beta_n          Chiang's azimuthal roughness (0..1; pbrt's and Mitsuba's default 0.3)
    chiang_size     Chiang table resolution: theta_o texels (phi: twice as many)
    multiple_scattering  "auto", "none", "karis" or "dual"
    near_field      Chiang's fibre: True shades a fibre wider than a pixel, in each pixel, as
                    the mean over the part of its width the pixel covers (the near field, which
                    pbrt and Mitsuba evaluate at each ray's hit; a table of its running
                    integral over the offset h, chiang.near_table), so a wide fibre shows its
                    highlights where they lie across it, as the path tracer does; a fibre
                    under a pixel wide gets the mean over its whole width, the far field.
                    False (the default until its cost on a GPU is measured: the default
                    strands are 1-3 px wide in issue 14's close-ups): the far field everywhere;
                    a still picture's frames draw with it all the same
                    (RenderSettings.still_near_field)
    lut_size        Marschner LUT resolution (M: lut_size^2, N: 2 lut_size x lut_size)
    dual_density_front  Zinke's d_f (forward-scattering density factor; the paper's 0.6-0.8
                    discounted counting every occluder as a fibre met; with the Poisson count
                    from the deep opacity map's own transmittance the packing is already in n,
                    so 1: measured against the path tracer, docs/quality.md)
    dual_density_back   Zinke's d_b (back-scattering density factor; the paper's 0.6-0.8 stands
                    for hair that is not a dense volume everywhere; with deep opacity maps the
                    multiple scattering is scaled by the share of light meeting hair beyond the
                    point, which measures that, so 1: against the path tracer, docs/quality.md)
    dual_max_hairs  cap on the number of fibres met towards the light, -log t (transmittance
                    0, e.g. the head's shadow, gives this many)
    dual_size       dual-scattering table resolution (texels per row, 7 rows)
    tables          "exact" (the Chiang and dual-scattering tables built for this material,
                    ~1 s of NumPy each new material) or "interpolated" (from tables at a fixed
                    grid of absorptions, built once per machine: for materials that change every
                    frame, as in a data set; table_family.py, within 2% of exact)
    """

    model: str = "chiang"
    color: tuple | None = None
    melanin: tuple | None = (1.3, 0.2)
    sigma_a: tuple | None = None
    specular: float = 1.0
    roughness: float = math.radians(7.5)
    shift: float = math.radians(-5.0)
    eta: float = 1.55
    glint: float = 1.0
    caustic_width: float = math.radians(15.0)
    caustic_fade: float = 0.3
    caustic_limit: float = 0.5
    tt_width: float = math.radians(25.0)
    glint_width: float = math.radians(5.0)
    noise: float = 0.1
    energy_clamp: bool = True
    beta_n: float = 0.3
    chiang_size: int = 64
    multiple_scattering: str = "auto"
    near_field: bool = False
    lut_size: int = 256
    dual_density_front: float = 1.0
    dual_density_back: float = 1.0
    dual_max_hairs: float = 64.0
    dual_size: int = 64
    tables: str = "exact"

    def __post_init__(self):
        self._check_numbers()
        if self.model not in MODELS:
            raise ValueError(f"unknown hair model {self.model!r}; one of {sorted(MODELS)}")
        if self.multiple_scattering != "auto" and self.multiple_scattering not in MULTIPLE_SCATTERING:
            raise ValueError(f"unknown multiple_scattering {self.multiple_scattering!r}")
        if not self.roughness > 0:
            raise ValueError("roughness (beta_R, radians) must be > 0")
        if not self.eta > 1:
            raise ValueError("eta must be > 1")
        if not self.dual_max_hairs > 0:
            raise ValueError("dual_max_hairs must be > 0")
        if not 0 < self.beta_n <= 1:
            raise ValueError("beta_n (Chiang's azimuthal roughness) must be in (0, 1]")
        if self.tables not in TABLES:
            raise ValueError(f"tables must be one of {', '.join(TABLES)}, got {self.tables!r}")
        if self.color is not None:
            if len(tuple(self.color)) != 3:
                raise ValueError("color must be linear R, G, B")
            object.__setattr__(self, "melanin", None)    # the RGB opt-in replaces melanin
        if isinstance(self.melanin, str):
            object.__setattr__(self, "melanin", hair_preset(self.melanin))   # a preset's name
        if self.melanin is not None and len(tuple(self.melanin)) != 2:
            raise ValueError("melanin must be (eumelanin, pheomelanin)")

    def _check_numbers(self) -> None:
        """Every number a real, finite value in its range (NaN, infinities and absurd table sizes
        are refused here, not found later as a non-finite table or an allocation that cannot be
        made)."""
        def real(name, x):
            if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or not math.isfinite(x):
                raise ValueError(f"{name} must be a finite number, got {x!r}")
            return float(x)

        for name, (lo, hi) in NUMBER_RANGES.items():
            x = real(name, getattr(self, name))
            if not lo <= x <= hi:
                raise ValueError(f"{name} must be in [{lo:g}, {hi:g}], got {x:g}")
        for name in ("energy_clamp", "near_field"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name} must be true or false, got {getattr(self, name)!r}")
        for name, (lo, hi) in TABLE_SIZES.items():
            x = real(name, getattr(self, name))
            if x != int(x) or not lo <= x <= hi:
                raise ValueError(f"{name} must be a whole number in [{lo}, {hi}], got {x:g}")
        for name, n, hi in (("melanin", 2, MELANIN_MAX), ("sigma_a", 3, SIGMA_A_MAX), ("color", 3, COLOR_MAX)):
            v = getattr(self, name)
            if v is None or isinstance(v, str):
                continue
            v = tuple(v)
            if len(v) != n:
                continue   # the length checks below say what is wanted
            for x in v:
                if not 0.0 <= real(name, x) <= hi:
                    raise ValueError(f"{name} values must be in [0, {hi:g}], got {v}")

    # ---------------------------------------------------------------- derived values
    @property
    def model_id(self) -> int:
        return MODELS[self.model]

    @property
    def resolved_multiple_scattering(self) -> str:
        """The multiple-scattering name "auto" stands for: "dual" (Zinke's dual scattering from
        the material's fibre, Chiang's or Marschner's) for every model. Karis's approximation
        measured 3.3-3.9x (and with one fibre's colour 9x) the path tracer's brightness."""
        if self.multiple_scattering == "auto":
            return "dual"
        return self.multiple_scattering

    @property
    def ms_mode(self) -> int:
        return MULTIPLE_SCATTERING[self.resolved_multiple_scattering]

    def _derived(self, name: str, make):
        """A value made from the (frozen) fields, made once per object: the renderer binds the
        material every frame, and melanin's sigma_a and the tables' keys cost NumPy work."""
        d = self.__dict__
        out = d.get(name)
        if out is None:
            out = d[name] = make()
        return out

    def resolved_sigma_a(self) -> np.ndarray:
        return self._derived("_sigma_a", self._resolve_sigma_a).copy()

    def _resolve_sigma_a(self) -> np.ndarray:
        if self.sigma_a is not None:
            return np.asarray(self.sigma_a, dtype=np.float64).reshape(3)
        if self.color is not None:
            if self.model in FIBRE_COLOURS:   # their colour made from Chiang's fibre, inverted
                return FIBRE_COLOURS[self.model][1](self.color, *self._fibre)
            if self.model in COLOUR_MODELS:
                return fibre_color_to_sigma_a(self.color)
            return color_to_sigma_a(self.color, self.beta_n)
        return melanin_to_sigma_a(*(self.melanin if self.melanin is not None else PRESETS["brown"]))

    def resolved_color(self) -> np.ndarray:
        """The ``color`` the model reads: Kajiya-Kay's diffuse albedo (twice what Chiang's
        TT, TRT and longer paths send back toward the light, kajiya_kay.py) and Scheuermann's
        diffuse colour made from it (scheuermann.color), the fibre colour (Karis's C =
        exp(-4 sigma_a)) for Sadeghi and Karis, the volume colour (Chiang eq. 9) for the fibre
        models (their ambient term)."""
        if self.color is not None and self.sigma_a is None:
            return np.asarray(self.color, dtype=np.float64).reshape(3)
        if self.model in FIBRE_COLOURS:
            return self._derived("_fibre_color", lambda: FIBRE_COLOURS[self.model][0](
                self.resolved_sigma_a(), *self._fibre)).copy()
        if self.model in COLOUR_MODELS:
            return fibre_color(self.resolved_sigma_a())
        return sigma_a_to_color(self.resolved_sigma_a(), self.beta_n)

    def defines(self) -> dict:
        """GLSL defines: the model, the multiple-scattering mode and the model constants."""
        return {
            "HAIR_MODEL": self.model_id,
            "HAIR_MULTIPLE_SCATTERING": self.ms_mode,
            "HAIR_CAUSTIC_WIDTH": _glsl_float(self.caustic_width),
            "HAIR_CAUSTIC_FADE": _glsl_float(self.caustic_fade),
            "HAIR_CAUSTIC_LIMIT": _glsl_float(self.caustic_limit),
            "HAIR_TT_WIDTH": _glsl_float(self.tt_width),
            "HAIR_GLINT_WIDTH": _glsl_float(self.glint_width),
            "HAIR_SHIFT_NOISE": _glsl_float(self.noise),
            "HAIR_ENERGY_CLAMP": int(bool(self.energy_clamp)),
            "HAIR_DUAL_DF": _glsl_float(self.dual_density_front),
            "HAIR_DUAL_DB": _glsl_float(self.dual_density_back),
            "HAIR_DUAL_MAX_HAIRS": _glsl_float(self.dual_max_hairs),
            **({NORM_DEFINES[self.model]: _glsl_float(self.model_norm)} if self.model in NORM_DEFINES else {}),
            **({"HAIR_NEAR_FIELD": 1, "HAIR_CHIANG_S": _glsl_float(chiang.logistic_scale(self.beta_n))}
               if self.near else {}),
        }

    @property
    def near(self) -> bool:
        """Whether hair_bsdf has Chiang's near field (``near_field`` with the Chiang model)."""
        return self.model == "chiang" and bool(self.near_field)

    @property
    def _fibre(self) -> tuple:
        """(eta, beta_n, roughness, shift): what kajiya_kay.py reads of Chiang's fibre."""
        return float(self.eta), float(self.beta_n), float(self.roughness), float(self.shift)

    @property
    def model_norm(self) -> float | None:
        """The drawn model's scale to Chiang's R albedo (its GLSL define NORM_DEFINES[model]):
        Kajiya-Kay's highlight (kajiya_kay.specular_norm), Sadeghi's whole function
        (sadeghi.norm), Scheuermann's highlights (scheuermann.norm); None for the other models.
        ~0.05 s of NumPy, so only the drawn model's, once per settings object."""
        make = NORMS.get(self.model)
        return None if make is None else self._derived("_model_norm", lambda: make(*self._fibre))

    def material_uniforms(self, prefix: str = "u_material") -> dict:
        """Values of ``uniform HairMaterial <prefix>`` fields ('u_material.color': (r, g, b), ...).

        strand_rand is 0 here: the shader sets it per strand.
        """
        c = self.resolved_color()
        s = self.resolved_sigma_a()
        return {
            f"{prefix}.color": tuple(float(x) for x in c),
            f"{prefix}.specular": float(self.specular),
            f"{prefix}.sigma_a": tuple(float(x) for x in s),
            f"{prefix}.roughness": float(self.roughness),
            f"{prefix}.shift": float(self.shift),
            f"{prefix}.eta": float(self.eta),
            f"{prefix}.glint": float(self.glint),
            f"{prefix}.strand_rand": 0.0,
        }

    def lut_key(self) -> tuple:
        return self._derived("_lut_key", self._lut_key)

    def _lut_key(self) -> tuple:
        return (tuple(np.round(self.resolved_sigma_a(), 9)), float(self.eta), float(self.roughness),
                float(self.shift), float(self.glint), float(self.caustic_width),
                float(self.caustic_fade), float(self.caustic_limit), bool(self.energy_clamp),
                int(self.lut_size))

    def luts(self):
        """(m_lut, n_lut) float32 arrays for this material (see luts.build_marschner_luts)."""
        from .luts import build_marschner_luts

        sigma_a = np.asarray(self.resolved_sigma_a(), np.float64)
        args = dict(eta=float(self.eta), beta_r=float(self.roughness), alpha_r=float(self.shift),
                    glint=float(self.glint), caustic_width=float(self.caustic_width),
                    caustic_fade=float(self.caustic_fade), caustic_limit=float(self.caustic_limit),
                    size=int(self.lut_size))                       # the energy clamp: in the shader
        return _stored("marschner_luts", (tuple(float(x) for x in sigma_a), sorted(args.items())),
                       lambda: build_marschner_luts(sigma_a, **args))

    def chiang_key(self) -> tuple:
        return self._derived("_chiang_key", self._chiang_key)

    def _chiang_key(self) -> tuple:
        return (tuple(np.round(self.resolved_sigma_a(), 9)), float(self.eta), float(self.beta_n),
                int(self.chiang_size))

    def chiang_table(self) -> np.ndarray:
        """(chiang_size, 6 chiang_size, 4) float32 data of ``hair_chiang_n`` (chiang.py), cached."""
        key = self.chiang_key()
        if self.tables == "interpolated":
            from .table_family import interpolated

            return interpolated("chiang", key[1:], key[0], lambda s: _build_chiang_table((tuple(s),) + key[1:]))
        return _chiang_table(key)

    @property
    def beta_m(self) -> float:
        """Chiang's / Mitsuba's longitudinal roughness equivalent to ``roughness``: the R lobe's
        standard deviation in theta_o, sqrt(v_0) = 0.726 beta_m + 0.812 beta_m^2 + 3.7 beta_m^20
        (Chiang eq. 7), is twice ``roughness`` (Marschner's beta_R is a width in theta_h =
        (theta_i + theta_o) / 2); tests/test_chiang.py checks it against Mitsuba's own lobe."""
        from .chiang import beta_m_from_roughness

        return beta_m_from_roughness(self.roughness)

    # the names mane.reference.HairMaterial.from_shading reads (Mitsuba's parameter names)
    longitudinal_roughness = beta_m

    @property
    def azimuthal_roughness(self) -> float:
        return float(self.beta_n)

    def dual_key(self) -> tuple:
        return self._derived("_dual_key", self._dual_key)

    def _dual_key(self) -> tuple:
        return (tuple(np.round(self.resolved_sigma_a(), 9)), float(self.eta), float(self.roughness),
                float(self.shift), float(self.glint), float(self.caustic_width),
                float(self.caustic_fade), float(self.caustic_limit), bool(self.energy_clamp),
                float(self.specular), float(self.dual_density_back), int(self.dual_size),
                "chiang" if self.model == "chiang" else "marschner", float(self.beta_n))

    def dual_tables(self):
        """Zinke 2008 tables (dual_scattering.DualTables) of this material, cached."""
        return _dual_tables(self.dual_key())

    def dual_lut(self) -> np.ndarray:
        """(9, dual_size, 4) float32 data of the ``hair_dual_lut`` texture (dual_scattering.py)."""
        from .dual_scattering import build_dual_lut

        key = self.dual_key()
        if self.tables == "interpolated":
            from .table_family import interpolated

            return interpolated("dual", key[1:], key[0], lambda s: build_dual_lut(_dual_tables((tuple(s),) + key[1:])))
        return _dual_lut(key).copy()     # a fresh array, as it always was

    def bind(self, program, ctx, *, prefix: str = "u_material", unit_m: int = LUT_UNIT_M,
             unit_n: int = LUT_UNIT_N, unit_dual: int = LUT_UNIT_DUAL) -> None:
        """Set the material uniforms that ``program`` uses and, for the LUT model, bind the
        lookup textures (built once per context and material) to ``unit_m`` / ``unit_n``;
        for dual scattering the ``hair_dual_lut`` texture to ``unit_dual``. What a program gets
        (its uniforms, their values, the textures) is found once per (program, material) and
        kept on the program; a value the uniform was last written is skipped by identity."""
        units = (prefix, unit_m, unit_n, unit_dual)
        # kept on the program: (settings, units, the uniforms' values, ((texture, unit), ...))
        plan = program.__dict__.get("_mane_material")
        if plan is None or plan[0] is not self or plan[1] != units or _released(plan[3]):   # a cache let one go
            values = dict(self.material_uniforms(prefix))
            textures = []
            if self.model == "marschner_lut":
                tex_m, tex_n = lut_textures(ctx, self)
                textures += [(tex_m, unit_m), (tex_n, unit_n)]
                values.update(hair_lut_m=unit_m, hair_lut_n=unit_n)
            if self.model == "chiang":
                textures.append((chiang_texture(ctx, self), LUT_UNIT_CHIANG))
                values["hair_chiang_n"] = LUT_UNIT_CHIANG
            if self.near:
                textures.append((chiang_near_texture(ctx, self), LUT_UNIT_CHIANG_NEAR))
                values["hair_chiang_c"] = LUT_UNIT_CHIANG_NEAR
            if self.ms_mode == MULTIPLE_SCATTERING["dual"]:
                textures.append((dual_lut_texture(ctx, self), unit_dual))
                values["hair_dual_lut"] = unit_dual
            plan = program.__dict__["_mane_material"] = (self, units, values, tuple(textures))
        set_uniforms(program, plan[2])   # kept dict: its uniforms looked up once, unchanged ones skipped
        for tex, unit in plan[3]:
            tex.use(unit)


def _released(textures) -> bool:
    """Whether a texture of ((texture, unit), ...) has been released."""
    for t, _ in textures:
        if isinstance(t.mglo, InvalidObject):
            return True
    return False


def _stored(kind: str, key, build) -> tuple:
    """``build()``'s arrays from the disk cache (``mane.disk_cache``, ``~/.cache/mane/KIND``),
    keyed by ``key`` (every input of the build) and the tables' code (``table_family.CODE``):
    a material's tables cost up to a few seconds of NumPy (Chiang's: ~0.06 s), which every start of
    a viewer or a render paid."""
    from ... import disk_cache
    from .table_family import CODE

    with phase("shading_tables"):
        out = disk_cache.arrays(kind, disk_cache.digest(kind, key, CODE), lambda: _as_tuple(build()))
    return out if len(out) > 1 else out[0]


def _as_tuple(x) -> tuple:
    return tuple(x) if isinstance(x, tuple) else (x,)


@functools.lru_cache(maxsize=32)
def _chiang_table(key: tuple) -> np.ndarray:
    """The exact table of ``chiang_key()`` (in memory, then on disk)."""
    return _stored("chiang", key, lambda: _build_chiang_table(key))


@functools.lru_cache(maxsize=32)
def _dual_lut(key: tuple) -> np.ndarray:
    """The exact ``hair_dual_lut`` data of ``dual_key()`` (in memory, then on disk)."""
    from .dual_scattering import build_dual_lut

    return _stored("dual_lut", key, lambda: build_dual_lut(_dual_tables(key)))


def _build_chiang_table(key: tuple) -> np.ndarray:
    from .chiang import azimuthal_table

    sigma_a, eta, beta_n, size = key
    return azimuthal_table(np.asarray(sigma_a, np.float64), eta=eta, beta_n=beta_n, n_phi=2 * size, n_theta=size)


@functools.lru_cache(maxsize=4)
def _chiang_near_table(key: tuple) -> np.ndarray:
    """``chiang.near_table`` of ``chiang_key()``, in memory only: its NumPy (~0.04 s) costs less
    than reading its 6.4 MB, and a data set's material per sample must not fill a disk."""
    from .chiang import near_table

    sigma_a, eta, beta_n, _ = key
    return near_table(np.asarray(sigma_a, np.float64), eta=eta, beta_n=beta_n)


_chiang_cache: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_chiang_near_cache: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _table_texture(ctx, caches, key, make):
    """An RGBA32F texture of the (rows, columns, 4) table ``make()``, linear filtering, clamped;
    cached per context (``caches``: a WeakKeyDictionary) and ``key``, the TEXTURES_PER_CONTEXT
    last used (a frame binds its material's textures when it draws, so an evicted one is unused)."""
    import moderngl

    cache = caches.setdefault(ctx, OrderedDict())
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    data = make()
    raw = np.ascontiguousarray(data, np.float32).tobytes()
    if data.ndim == 4:   # (layers, rows, columns, 4): a 3D texture
        tex = ctx.texture3d((data.shape[2], data.shape[1], data.shape[0]), 4, raw, dtype="f4")
        tex.repeat_z = False
    else:
        tex = ctx.texture((data.shape[1], data.shape[0]), 4, raw, dtype="f4")
    tex.repeat_x = tex.repeat_y = False
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    cache[key] = tex
    while len(cache) > TEXTURES_PER_CONTEXT:   # a material per sample must not fill the GPU
        cache.popitem(last=False)[1].release()
    return tex


def chiang_texture(ctx, settings: ShadingSettings):
    """The ``hair_chiang_n`` texture: (6 chiang_size x chiang_size) RGBA32F; cached per context
    and ``settings.chiang_key()``."""
    return _table_texture(ctx, _chiang_cache, (settings.tables,) + settings.chiang_key(), settings.chiang_table)


def chiang_near_texture(ctx, settings: ShadingSettings):
    """The ``hair_chiang_c`` texture (``chiang.near_table``: 192 x 32 x 65 RGBA32F, 6.4 MB), built
    for the material whatever ``settings.tables`` (its NumPy costs ~0.04 s); cached per context
    and ``settings.chiang_key()``."""
    key = settings.chiang_key()
    return _table_texture(ctx, _chiang_near_cache, key, lambda: _chiang_near_table(key))


@functools.lru_cache(maxsize=32)
def _dual_tables(key: tuple):
    from .dual_scattering import precompute_dual

    (sigma_a, eta, roughness, shift, glint, caustic_width, caustic_fade, caustic_limit, energy_clamp,
     specular, d_b, size, kind, beta_n) = key
    return precompute_dual(np.asarray(sigma_a, np.float64), eta=eta, beta_r=roughness, alpha_r=shift,
                           glint=glint, caustic_width=caustic_width, caustic_fade=caustic_fade,
                           caustic_limit=caustic_limit, energy_clamp=energy_clamp, specular=specular,
                           d_b=d_b, size=size, model=kind, beta_n=beta_n)


_dual_cache: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def dual_lut_texture(ctx, settings: ShadingSettings):
    """The ``hair_dual_lut`` moderngl texture: (dual_size x 8) RGBA32F; cached per context and
    ``settings.dual_key()``."""
    return _table_texture(ctx, _dual_cache, (settings.tables,) + settings.dual_key(), settings.dual_lut)


_lut_cache: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def lut_textures(ctx, settings: ShadingSettings):
    """(hair_lut_m, hair_lut_n) moderngl textures, RGBA16F, linear filtering, clamped; cached
    per context and ``settings.lut_key()``."""
    cache = _lut_cache.setdefault(ctx, OrderedDict())
    key = settings.lut_key()
    if key in cache:
        cache.move_to_end(key)
    else:
        m_lut, n_lut = settings.luts()
        textures = []
        for arr in (m_lut, n_lut):
            h, w = arr.shape[:2]
            tex = ctx.texture((w, h), 4, np.ascontiguousarray(arr, dtype=np.float16).tobytes(), dtype="f2")
            tex.repeat_x = tex.repeat_y = False
            import moderngl

            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            textures.append(tex)
        cache[key] = tuple(textures)
        while len(cache) > TEXTURES_PER_CONTEXT:
            for tex in cache.popitem(last=False)[1]:
                tex.release()
    return cache[key]


def evaluate_glsl(ctx, model: str | ShadingSettings, T, V, L, settings: ShadingSettings | None = None,
                  *, strand_rand=None, transmittance=None, multiple: bool = False, h=None,
                  footprint: float = 0.0) -> np.ndarray:
    """Run hair_bsdf (or, ``multiple=True``, hair_multiple_scattering) in a compute shader
    (harness.comp) on N rows of unit T, V, L; returns (N, 3) float32. ``h``: Chiang's near
    field (``near_field`` on; the other models ignore it) at these offsets across the fibre
    (-1 .. 1 along cross(T, V)): its mean over h +- ``footprint`` / 2 (clipped to the fibre), or
    under chiang.glsl's HAIR_NEAR_MIN_DH the fibre at h.

    ``model`` names the model (overriding settings.model) or is the settings itself.
    """
    import dataclasses

    from ...gpu.glsl import compute_shader

    if isinstance(model, ShadingSettings):
        settings = model
    else:
        settings = dataclasses.replace(settings or ShadingSettings(), model=model)
    T = np.asarray(T, np.float32).reshape(-1, 3)
    V = np.asarray(V, np.float32).reshape(-1, 3)
    L = np.asarray(L, np.float32).reshape(-1, 3)
    n = T.shape[0]
    rand = np.zeros(n, np.float32) if strand_rand is None else np.broadcast_to(np.asarray(strand_rand, np.float32), (n,))
    trans = np.ones(n, np.float32) if transmittance is None else np.broadcast_to(np.asarray(transmittance, np.float32), (n,))
    data = np.zeros((n, 3, 4), np.float32)
    data[:, 0, :3], data[:, 0, 3] = T, rand
    data[:, 1, :3], data[:, 1, 3] = V, trans
    data[:, 2, :3] = L
    if h is not None:
        data[:, 2, 3] = np.broadcast_to(np.asarray(h, np.float32), (n,))
    shader = compute_shader(ctx, HARNESS_COMP, defines=settings.defines())
    src = ctx.buffer(data.tobytes())
    dst = ctx.buffer(reserve=max(n, 1) * 32)
    try:
        src.bind_to_storage_buffer(B_HARNESS_SAMPLES)
        dst.bind_to_storage_buffer(B_HARNESS_RESULTS)
        settings.bind(shader, ctx)
        write_uniform(shader["u_count"], n)
        if "u_near" in shader:
            write_uniform(shader["u_near"], int(h is not None))
            write_uniform(shader["u_near_dh"], float(footprint))
        shader.run((n + 63) // 64)
        ctx.memory_barrier()
        out = np.frombuffer(dst.read(), np.float32).reshape(-1, 2, 4)[:n]
    finally:
        src.release()
        dst.release()
    return out[:, 1 if multiple else 0, :3].copy()


__all__ = [
    "MODELS", "MULTIPLE_SCATTERING", "ShadingSettings", "HAIR_SHADING_GLSL", "SHADER_DIR",
    "melanin_to_sigma_a", "color_to_sigma_a", "sigma_a_to_color", "build_marschner_luts",
    "lut_textures", "evaluate_glsl", "dual_lut_texture", "LUT_UNIT_DUAL", "LUT_UNIT_CHIANG",
    "chiang_texture", "PRESETS", "hair_preset", "fibre_color", "FIBRE_MODELS", "COLOUR_MODELS",
]


def build_marschner_luts(*args, **kwargs):
    """See luts.build_marschner_luts."""
    from .luts import build_marschner_luts as _build

    return _build(*args, **kwargs)
