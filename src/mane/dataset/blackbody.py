"""A black body's colour at a temperature, as linear sRGB of unit luminance (light colours).

Planck's law integrated against the CIE 1931 2-degree colour matching functions (the
multi-lobe Gaussian fit of Wyman, Sloan and Shirley 2013, JCGT 2(2)), XYZ -> linear sRGB (D65),
negative channels clipped, scaled to luminance Y = 1.
"""
from __future__ import annotations

import numpy as np

C2 = 1.4387769e-2          # second radiation constant h c / k, m K
WAVELENGTHS = np.arange(360.0, 831.0, 1.0)   # nm
XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986],
                        [-0.9689, 1.8758, 0.0415],
                        [0.0557, -0.2040, 1.0570]])


def _g(lam, mu, s1, s2):
    s = np.where(lam < mu, s1, s2)
    return np.exp(-0.5 * ((lam - mu) / s) ** 2)


def cie_1931(lam) -> np.ndarray:
    """(N, 3) x-bar, y-bar, z-bar at wavelengths ``lam`` (nm)."""
    lam = np.asarray(lam, np.float64)
    x = 1.056 * _g(lam, 599.8, 37.9, 31.0) + 0.362 * _g(lam, 442.0, 16.0, 26.7) - 0.065 * _g(lam, 501.1, 20.4, 26.2)
    y = 0.821 * _g(lam, 568.8, 46.9, 40.5) + 0.286 * _g(lam, 530.9, 16.3, 31.1)
    z = 1.217 * _g(lam, 437.0, 11.8, 36.0) + 0.681 * _g(lam, 459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1)


_CMF = cie_1931(WAVELENGTHS)
_LAM = WAVELENGTHS * 1e-9


def blackbody_xyz(kelvin: float) -> np.ndarray:
    """CIE XYZ of a black body at ``kelvin``, scaled to Y = 1."""
    spd = _LAM ** -5 / np.expm1(C2 / (_LAM * float(kelvin)))
    xyz = spd @ _CMF
    return xyz / xyz[1]


def blackbody_rgb(kelvin: float) -> tuple[float, float, float]:
    """Linear sRGB of a black body at ``kelvin`` (1000..40000 K), luminance 1, no negatives."""
    rgb = np.clip(XYZ_TO_SRGB @ blackbody_xyz(kelvin), 0.0, None)
    y = float(rgb @ np.array([0.2126, 0.7152, 0.0722]))
    return tuple(float(v) for v in rgb / y)
