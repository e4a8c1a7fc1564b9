"""Hair colour from melanin, and absorption from an RGB colour.

Absorption coefficients are per unit fibre RADIUS (the pbrt-v3 / Chiang et al. 2016
convention, h in [-1, 1]): a ray through the centre of the fibre in the normal plane
travels 2 radii and is attenuated by exp(-2 sigma_a).

``melanin_to_sigma_a`` uses Chiang, Bitterli, Tappan and Burley 2016, "A Practical and
Controllable Hair and Fur Model for Production Path Tracing" (sec. 4.3, after d'Eon et al.
2011 / Donner and Jensen), the per-unit-concentration absorption of the two pigments at
the R, G, B wavelengths:

    eumelanin   (0.419, 0.697, 1.37)
    pheomelanin (0.187, 0.4,   1.05)
    sigma_a = C_eu * eumelanin + C_pheo * pheomelanin

Concentrations are in [0, ~8]: ~0.3 blond, ~1.3 brown, ~8 black (pbrt's scale).

``color_to_sigma_a`` is Chiang 2016 eq. 9 (the inverse of the multiple-scattered colour of
a hair volume), with azimuthal roughness beta_n:

    sigma_a = (ln(c) / (5.969 - 0.215 b + 2.532 b^2 - 10.73 b^3 + 5.574 b^4 + 0.245 b^5))^2

and ``sigma_a_to_color`` its inverse, c = exp(-sqrt(sigma_a) * f(b)): the colour of a
multiple-scattering hair VOLUME, not of one fibre.

``fibre_color`` is one fibre's colour, C = exp(-4 sigma_a): Karis 2016 writes the TT
transmittance as C^(sqrt(1 - h^2 a^2) / (2 cos theta_d)), which at h = 0, theta_d = 0 is
C^(1/2) = exp(-2 sigma_a), the transmittance through the fibre's centre (2 radii). This is the
colour the colour-driven models (Kajiya-Kay, Sadeghi, Scheuermann, Karis) take from melanin.

``PRESETS``: named (eumelanin, pheomelanin) pairs. Chiang et al. 2016 (Fig. 8) and pbrt-v4's
documentation give eumelanin ~8 black, ~1.3 brown, ~0.3 blond; Mitsuba's ``hair`` example uses
eumelanin 1.3 / pheomelanin 0.2 for brown. Red and auburn hair are pheomelanin-rich (d'Eon
et al. 2011; Ito and Wakamatsu 2011 measure pheomelanin-dominant red hair and mixed
eu/pheo auburn), platinum blond is nearly pigment-free. Grey hair is, in a real head, a mix
of unpigmented (white) and pigmented fibres (canities); with one material per groom mane
approximates its average by little eumelanin and no pheomelanin (the least yellow cast melanin
allows: eumelanin itself absorbs blue 3.3x more than red, so a neutral grey is out of its reach;
a salt-and-pepper head needs two grooms, white and dark).
"""
from __future__ import annotations

import numpy as np

PRESETS: dict[str, tuple[float, float]] = {
    "black": (8.0, 0.0),
    "dark_brown": (3.0, 0.3),
    "brown": (1.3, 0.2),
    "light_brown": (0.65, 0.15),
    "auburn": (0.8, 1.0),
    "red": (0.2, 1.6),
    "blond": (0.3, 0.1),
    "platinum": (0.06, 0.02),
    "grey": (0.12, 0.0),
}

MELANIN_MAX = 50.0   # the concentrations accepted: Chiang's run 0..8; far past it every fibre is black

EUMELANIN_SIGMA_A = (0.419, 0.697, 1.37)
PHEOMELANIN_SIGMA_A = (0.187, 0.4, 1.05)
DEFAULT_BETA_N = 0.3


def melanin_to_sigma_a(eumelanin: float, pheomelanin: float = 0.0) -> np.ndarray:
    """RGB absorption per unit radius for the two pigment concentrations (Chiang 2016)."""
    ce = float(eumelanin)
    cp = float(pheomelanin)
    if ce < 0 or cp < 0:
        raise ValueError("melanin concentrations must be >= 0")
    return ce * np.asarray(EUMELANIN_SIGMA_A) + cp * np.asarray(PHEOMELANIN_SIGMA_A)


def _chiang_f(beta_n: float) -> float:
    b = float(beta_n)
    return 5.969 - 0.215 * b + 2.532 * b**2 - 10.73 * b**3 + 5.574 * b**4 + 0.245 * b**5


def color_to_sigma_a(color, beta_n: float = DEFAULT_BETA_N) -> np.ndarray:
    """Chiang 2016 eq. 9: the absorption whose hair volume looks ``color`` (linear RGB)."""
    c = np.clip(np.asarray(color, dtype=np.float64), 1e-4, 1.0)
    return (np.log(c) / _chiang_f(beta_n)) ** 2


def sigma_a_to_color(sigma_a, beta_n: float = DEFAULT_BETA_N) -> np.ndarray:
    """The inverse of ``color_to_sigma_a``: the linear RGB colour of a hair volume."""
    s = np.maximum(np.asarray(sigma_a, dtype=np.float64), 0.0)
    return np.exp(-np.sqrt(s) * _chiang_f(beta_n))


def preset_names() -> str:
    """The presets' names, comma-separated (command-line help)."""
    return ", ".join(PRESETS)


def hair_preset(name: str) -> tuple[float, float]:
    """(eumelanin, pheomelanin) of a named preset (``PRESETS``); "dark brown" = "dark_brown"."""
    key = str(name).strip().lower().replace(" ", "_").replace("-", "_")
    if key not in PRESETS:
        from ...errors import UsageError

        raise UsageError(f"unknown hair preset {name!r}; one of {', '.join(PRESETS)}")
    return PRESETS[key]


def fibre_color(sigma_a) -> np.ndarray:
    """One fibre's colour C = exp(-4 sigma_a) (Karis 2016's C; module docstring)."""
    return np.exp(-4.0 * np.maximum(np.asarray(sigma_a, dtype=np.float64), 0.0))


def fibre_color_to_sigma_a(color) -> np.ndarray:
    """The inverse of ``fibre_color``."""
    c = np.clip(np.asarray(color, dtype=np.float64), 1e-4, 1.0)
    return -np.log(c) / 4.0
