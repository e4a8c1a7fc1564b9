"""What the reference renderer draws, as plain arrays: the real-time renderer's own expanded
strands, its camera and lights, and the hair material in the path tracer's parameters.

    strands = expanded_strands(groom, settings, head=head)      # the GPU expand pass, read back
    ctrl, radii = bspline_control_points(strands.points, strands.widths / 2)
    material = HairMaterial.from_settings(settings)             # Chiang 2016 / Mitsuba parameters

No Mitsuba here (it is imported by ``mane.reference.render`` only).

Curves. The real-time renderer draws each rendered strand as the polyline through the points of
its expand pass (``ExpandPass.read()``: (strands, points, 8) = x, y, z, width, tangent, random).
Mitsuba's ``bsplinecurve`` is a uniform cubic B-spline, which passes near but not through its
control points (at a knot it is (C[j-1] + 4 C[j] + C[j+1]) / 6). Using the polyline's points as
control points would pull the curve inward by a sixth of the second difference, which for
curly hair is more than a strand's width; so ``bspline_control_points`` solves for the control
points whose B-spline interpolates every polyline point (a tridiagonal system per strand, ends
clamped by phantom points C[-1] = 2 C[0] - C[1]: the curve starts at the root and ends at the
tip). Between the points the B-spline is the smooth curve through them; the polyline is its
chord, off by less than a width for the renderer's segment counts (the tests measure it).
Radii (half the expanded width, root-to-tip taper included) are interpolated the same way.
``linearcurve`` is not used: it gives the hair BSDF a wrong fibre tangent.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

# pbrt-v3 / Chiang 2016: longitudinal standard deviation of the R lobe for a roughness beta_m,
# sqrt(v) = 0.726 beta_m + 0.812 beta_m^2 + 3.7 beta_m^20 (radians).
BETA_M_POLY = (0.726, 0.812, 3.7)
DEFAULT_AZIMUTHAL_ROUGHNESS = 0.3     # Chiang's beta_n default (mane.render.shading.melanin.DEFAULT_BETA_N)


def lobe_width_to_beta_m(width_rad: float) -> float:
    """Chiang's longitudinal roughness beta_m (0..1) whose R lobe has standard deviation
    ``width_rad`` (Marschner's beta_R, mane's ``ShadingSettings.roughness``): the root of
    0.726 b + 0.812 b^2 + 3.7 b^20 = width (monotone on [0, 1], bisection)."""
    w = float(width_rad)
    a1, a2, a20 = BETA_M_POLY
    if not w > 0:
        raise UsageError(f"the longitudinal width must be > 0 radians, got {width_rad}")
    f = lambda b: a1 * b + a2 * b * b + a20 * b ** 20 - w  # noqa: E731
    if f(1.0) < 0:
        raise UsageError(f"a longitudinal width of {math.degrees(w):.1f} degrees is beyond Chiang's roughness 1")
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


def beta_m_to_lobe_width(beta_m: float) -> float:
    a1, a2, a20 = BETA_M_POLY
    b = float(beta_m)
    return a1 * b + a2 * b * b + a20 * b ** 20


@dataclass(frozen=True)
class HairMaterial:
    """The path tracer's hair: Mitsuba's ``hair`` BSDF (Chiang et al. 2016, pbrt-v3's model).

    eumelanin, pheomelanin   pigment concentrations (used when ``sigma_a`` is None)
    sigma_a                  RGB absorption per unit fibre radius (overrides the pigments)
    longitudinal_roughness   Chiang's beta_m in [0, 1]
    azimuthal_roughness      Chiang's beta_n in [0, 1]
    tilt                     cuticle scale tilt alpha in degrees, in mane's convention (the sign of
                             ``ShadingSettings.shift``: negative moves the R highlight toward the
                             root, as Marschner's alpha_R = -5 deg); ``mitsuba_scale_tilt`` is the
                             value handed to Mitsuba for curves drawn root first
    eta                      index of refraction of the fibre
    """

    eumelanin: float = 1.3
    pheomelanin: float = 0.2
    sigma_a: tuple | None = None
    longitudinal_roughness: float = 0.3
    azimuthal_roughness: float = DEFAULT_AZIMUTHAL_ROUGHNESS
    tilt: float = -2.0
    eta: float = 1.55

    def __post_init__(self):
        if self.sigma_a is None and (self.eumelanin < 0 or self.pheomelanin < 0):
            raise UsageError("melanin concentrations must be >= 0")
        if self.sigma_a is not None:
            s = tuple(float(x) for x in np.asarray(self.sigma_a, float).reshape(3))
            if min(s) < 0 or not all(map(math.isfinite, s)):
                raise UsageError(f"sigma_a must be 3 finite numbers >= 0, got {self.sigma_a}")
            object.__setattr__(self, "sigma_a", s)
        for name in ("longitudinal_roughness", "azimuthal_roughness"):
            if not 0.0 < float(getattr(self, name)) <= 1.0:
                raise UsageError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        if not float(self.eta) > 1.0:
            raise UsageError(f"eta must be > 1, got {self.eta}")

    @property
    def mitsuba_scale_tilt(self) -> float:
        """Mitsuba's ``scale_tilt`` (degrees): a positive value moves R toward the curve's end,
        which for root-first curves is the tip; mane's negative shift moves it toward the root.
        Measured by tests/test_reference.py::test_tilt_moves_highlight_toward_root."""
        return float(self.tilt)

    def resolved_sigma_a(self) -> np.ndarray:
        from ..render.shading.melanin import melanin_to_sigma_a

        if self.sigma_a is not None:
            return np.asarray(self.sigma_a, float)
        return melanin_to_sigma_a(self.eumelanin, self.pheomelanin)

    def key(self) -> dict:
        return {"eumelanin": float(self.eumelanin), "pheomelanin": float(self.pheomelanin),
                "sigma_a": None if self.sigma_a is None else list(self.sigma_a),
                "beta_m": float(self.longitudinal_roughness), "beta_n": float(self.azimuthal_roughness),
                "tilt": float(self.tilt), "eta": float(self.eta)}

    @classmethod
    def from_shading(cls, shading) -> "HairMaterial":
        """From a ``mane.render.shading.ShadingSettings``: its melanin (else its absorption,
        from ``sigma_a`` or Chiang's inversion of ``color``), its longitudinal width
        ``roughness`` (beta_R, radians) mapped to beta_m, ``shift`` (alpha_R) as the tilt, its
        ``eta``; beta_n from an ``azimuthal_roughness`` field when the settings have one."""
        melanin = getattr(shading, "melanin", None)
        sigma = getattr(shading, "sigma_a", None)
        kw = {}
        if sigma is None and melanin is not None:
            kw.update(eumelanin=float(melanin[0]), pheomelanin=float(melanin[1]) if len(melanin) > 1 else 0.0)
        else:
            kw["sigma_a"] = tuple(float(x) for x in shading.resolved_sigma_a())
        beta_m = getattr(shading, "longitudinal_roughness", None)
        if beta_m is None:
            beta_m = lobe_width_to_beta_m(float(shading.roughness))
        beta_n = getattr(shading, "azimuthal_roughness", None)
        return cls(longitudinal_roughness=float(beta_m),
                   azimuthal_roughness=float(beta_n) if beta_n is not None else DEFAULT_AZIMUTHAL_ROUGHNESS,
                   tilt=math.degrees(float(shading.shift)), eta=float(shading.eta), **kw)

    @classmethod
    def from_settings(cls, settings) -> "HairMaterial":
        """From a ``RenderSettings``: the material the real-time renderer shades with (its
        ``shading``, ``shading_options`` and ``hair_color``, as ``Renderer`` builds them)."""
        from ..render.renderer import ShadingAdapter

        return cls.from_shading(ShadingAdapter(settings.shading, settings.hair_color, settings.shading_options).settings)


@dataclass
class ExpandedStrands:
    """The rendered strands as the real-time renderer draws them: points (S, N, 3) metres,
    widths (S, N) metres (full width, taper and LOD fade included), tangents (S, N, 3)."""

    points: np.ndarray
    widths: np.ndarray
    tangents: np.ndarray | None = None

    def __post_init__(self):
        self.points = np.ascontiguousarray(self.points, dtype=np.float32)
        self.widths = np.ascontiguousarray(self.widths, dtype=np.float32)
        if self.points.ndim != 3 or self.points.shape[2] != 3 or self.widths.shape != self.points.shape[:2]:
            raise UsageError(f"expanded strands need points (S, N, 3) and widths (S, N); got "
                             f"{self.points.shape} and {self.widths.shape}")
        if self.points.shape[1] < 2:
            raise UsageError("expanded strands need at least 2 points each")

    @property
    def count(self) -> int:
        return int(self.points.shape[0])

    def visible(self) -> "ExpandedStrands":
        """Without the strands of zero width (faded out by the distance LOD)."""
        keep = self.widths.max(axis=1) > 0
        return ExpandedStrands(self.points[keep], self.widths[keep],
                               None if self.tangents is None else self.tangents[keep])

    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        p = self.points.reshape(-1, 3)
        return p.min(axis=0).astype(float), p.max(axis=0).astype(float)

    @classmethod
    def from_expand_buffer(cls, data: np.ndarray) -> "ExpandedStrands":
        """From ``ExpandPass.read()``: (strands, points, 8) = x, y, z, width, tx, ty, tz, random."""
        data = np.asarray(data, np.float32)
        return cls(data[..., :3], data[..., 3], data[..., 4:7])


def renderer_strands(renderer) -> ExpandedStrands:
    """The strands a ``mane.render.Renderer`` draws in a still picture (settings.pipeline="compute";
    its ``still_segments``, Renderer.still_settings): its guide frames rebuilt and its expand pass
    run, then the buffer read back. The path tracer's B-spline through those points is the
    renderer's curve: through a moving frame's 32 segments, a curl's spline lay 0.09 px (median),
    0.46 px (90th percentile) off the curve mane draws in a still picture, against strands 0.28 px
    wide (the curly head; Sintel 0.002 px); through 64, 0.02 / 0.15 px (docs/quality.md)."""
    from ..render.passes.expand import pulls

    if renderer.strands is None:
        raise UsageError("the renderer has no strands (set_strands first)")
    if not pulls(renderer):
        raise UsageError("the reference reads the expand pass: RenderSettings(pipeline='compute', oit='none')")
    base = renderer.settings
    renderer.settings = base.replace(segments=renderer.still_settings().segments)
    try:
        if renderer.frames_dirty:
            renderer.get_pass("frames").run(None)
        return ExpandedStrands.from_expand_buffer(renderer.get_pass("expand").read())
    finally:
        renderer.settings = base


def expanded_strands(groom, settings=None, *, head=None, ctx=None) -> ExpandedStrands:
    """The rendered strands of ``groom`` under ``settings`` (interpolation, multiplication,
    clumps, strays, curl, widths), computed by the real-time renderer's own expand pass."""
    from ..render import Renderer, RenderSettings

    settings = settings if settings is not None else RenderSettings()
    settings = settings.replace(pipeline="compute", oit="none")
    r = Renderer(settings, ctx=ctx, profile=False)
    try:
        r.set_strands(groom)
        r.set_head(head)
        return renderer_strands(r)
    finally:
        r.release()


def _thomas(a: float, b: float, c: float, d: np.ndarray) -> np.ndarray:
    """Solve the constant tridiagonal system (a below, b on, c above the diagonal) for every
    right-hand side: d is (M, K...) with the system along axis 0."""
    m = d.shape[0]
    cp = np.empty(m)
    dp = np.empty_like(d, dtype=np.float64)
    cp[0] = c / b
    dp[0] = d[0] / b
    for i in range(1, m):
        den = b - a * cp[i - 1]
        cp[i] = c / den
        dp[i] = (d[i] - a * dp[i - 1]) / den
    x = np.empty_like(dp)
    x[-1] = dp[-1]
    for i in range(m - 2, -1, -1):
        x[i] = dp[i] - cp[i] * x[i + 1]
    return x


def bspline_control_points(points, radii=None) -> tuple[np.ndarray, np.ndarray | None]:
    """Control points (S, N + 2, 3) of the uniform cubic B-splines that pass through every
    polyline point (S, N, 3) at the knots and start and end at the first and last point; and
    the radii (S, N + 2) interpolated the same way when ``radii`` (S, N) is given.

    With C[0] = 2 C[1] - C[2] and C[N+1] = 2 C[N] - C[N-1] the ends are C[1] = P[0] and
    C[N] = P[N-1]; inside, C[j] + 4 C[j+1] + C[j+2] = 6 P[j]."""
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 3 or P.shape[1] < 2:
        raise UsageError(f"polylines must be (S, N >= 2, 3), got {P.shape}")

    def solve(values):                       # values (S, N, K) -> (S, N + 2, K)
        S, N, K = values.shape
        C = np.empty((S, N + 2, K))
        C[:, 1], C[:, N] = values[:, 0], values[:, -1]
        if N > 2:
            rhs = 6.0 * values[:, 1:N - 1].copy()          # equations j = 1 .. N-2, unknowns C[2..N-1]
            rhs[:, 0] -= values[:, 0]
            rhs[:, -1] -= values[:, -1]
            inner = _thomas(1.0, 4.0, 1.0, np.moveaxis(rhs, 1, 0))
            C[:, 2:N] = np.moveaxis(inner, 0, 1)
        C[:, 0] = 2 * C[:, 1] - C[:, 2]
        C[:, N + 1] = 2 * C[:, N] - C[:, N - 1]
        return C

    ctrl = solve(P)
    rad = None
    if radii is not None:
        R = np.asarray(radii, dtype=np.float64)
        if R.shape != P.shape[:2]:
            raise UsageError(f"radii must be (S, N) = {P.shape[:2]}, got {R.shape}")
        rad = np.maximum(solve(R[..., None])[..., 0], 0.0)
    return ctrl, rad


def bspline_eval(ctrl, t) -> np.ndarray:
    """Points of the uniform cubic B-spline with control points ``ctrl`` (S, M, K) at curve
    parameters ``t`` in [0, M - 3] (segment i spans [i, i + 1] and uses C[i..i+3])."""
    C = np.asarray(ctrl, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    nseg = C.shape[1] - 3
    i = np.clip(np.floor(t).astype(int), 0, nseg - 1)
    u = (t - i)[None, :, None]
    b0 = (1 - u) ** 3 / 6
    b1 = (3 * u ** 3 - 6 * u ** 2 + 4) / 6
    b2 = (-3 * u ** 3 + 3 * u ** 2 + 3 * u + 1) / 6
    b3 = u ** 3 / 6
    return b0 * C[:, i] + b1 * C[:, i + 1] + b2 * C[:, i + 2] + b3 * C[:, i + 3]
