"""Physical validation against closed forms: a pendulum's small-angle period, exponential
energy decay with the damping rate, self-convergence as dt shrinks (figures in
docs/quality.md, "Simulation")."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mane import Groom
from mane.sim import SimSettings, Simulator

pytestmark = pytest.mark.gpu
G = 9.81


def swing(gl, method, dt, seconds, damping=0.0, L=0.1, angle=0.1):
    """A stiff short strand: root pinned, one free particle at L (a rigid massless rod with a
    point mass), released at ``angle`` from the vertical; returns (t, x) of the free end."""
    rest = np.array([[[0.0, 1.0, 0.0], [L * math.sin(angle), 1.0 - L * math.cos(angle), 0.0]]])
    sim = Simulator(Groom.from_strands(list(rest)), [], SimSettings(length_method=method, dt=dt, damping=damping,
                                                                    max_substeps=1000), ctx=gl)
    n = int(round(seconds / dt))
    xs = np.empty(n)
    for i in range(n):
        sim.step()
        xs[i] = sim.positions()[1, 0]
    return dt * np.arange(1, n + 1), xs


def period(t, x):
    """Mean spacing of downward zero crossings (linear interpolation)."""
    i = np.nonzero((x[:-1] > 0) & (x[1:] <= 0))[0]
    tc = t[i] + (t[i + 1] - t[i]) * x[i] / (x[i] - x[i + 1])
    return float(np.diff(tc).mean())


def small_angle_period(L, angle):
    """2 pi sqrt(L/g) with the first finite-amplitude term (1 + angle^2 / 16)."""
    return 2 * math.pi * math.sqrt(L / G) * (1 + angle ** 2 / 16)


@pytest.mark.parametrize("method", ["dftl", "pbd"])
def test_pendulum_period(gl, method):
    t, x = swing(gl, method, 1 / 480, 2.0)
    want = small_angle_period(0.1, 0.1)
    got = period(t, x)
    assert abs(got / want - 1) < 0.01, (got, want)


def test_period_converges_as_dt_shrinks(gl):
    want = small_angle_period(0.1, 0.1)
    errs = [abs(period(*swing(gl, "dftl", dt, 2.0)) / want - 1) for dt in (1 / 60, 1 / 120, 1 / 480)]
    assert errs[2] < errs[1] < errs[0], errs


def decay_rate(gl, c, dt=1 / 480):
    t, x = swing(gl, "dftl", dt, 2.5, damping=c)
    peaks = [i for i in range(1, len(x) - 1) if x[i] > x[i - 1] and x[i] >= x[i + 1] and x[i] > 0]
    return float(-np.polyfit(t[peaks], np.log(x[peaks] ** 2), 1)[0])


def test_energy_decays_at_the_damping_rate(gl):
    """v *= exp(-c dt) a step is linear drag: the swing's energy (amplitude^2) falls as exp(-c t)
    on top of the solver's own dissipation (the projection's, O(dt), measured at c = 0)."""
    own = decay_rate(gl, 0.0)
    for c in (0.75, 1.5):
        rate = decay_rate(gl, c) - own
        assert abs(rate / c - 1) < 0.05, (rate, c, own)
    assert own < 0.3


def catenary(D, S, s):
    """Points at arc lengths s (from the middle) of the catenary of length S hung between (-D/2, 0)
    and (D/2, 0): a from S = 2 a sinh(D / 2a) (bisection), x = a asinh(s/a), y = a (cosh(x/a) - cosh(D/2a))."""
    lo, hi = 1e-4, 1e4
    for _ in range(200):
        a = math.sqrt(lo * hi)
        if 2 * a * math.sinh(D / (2 * a)) > S:
            lo = a
        else:
            hi = a
    x = a * np.arcsinh(s / a)
    return np.stack([x, a * (np.cosh(x / a) - math.cosh(D / (2 * a)))], axis=1)


def test_chain_pinned_at_both_ends_hangs_as_a_catenary(gl):
    """PBD (the direct chain solve handles two pinned ends): a chain of 33 equal masses, length
    0.4 m, ends 0.3 m apart, released from a V, settles onto the catenary (the discrete chain's
    nodes lie on it to O(1/N^2))."""
    N, S, D = 33, 0.4, 0.3
    depth = math.sqrt((S / 2) ** 2 - (D / 2) ** 2)
    t = np.abs(np.linspace(-1.0, 1.0, N))          # a V: both halves straight, equal segments
    rest = np.stack([np.linspace(-D / 2, D / 2, N), 1.0 - depth * (1 - t), np.zeros(N)], axis=1)
    pinned = np.zeros(N, bool)
    pinned[[0, -1]] = True
    groom = Groom.from_strands([rest], point_attributes={"immovable": pinned})
    sim = Simulator(groom, [], SimSettings(length_method="pbd", damping=6.0, dt=1 / 120), ctx=gl,
                    points_per_strand=N)
    for _ in range(360):
        sim.step()
    p = sim.positions().astype(np.float64)
    s = np.linspace(-S / 2, S / 2, N)
    want = catenary(D, S, s)
    got = np.stack([p[:, 0], p[:, 1] - 1.0], axis=1)
    sag = -want[:, 1].min()
    err = np.abs(got - want).max()
    assert sim.max_length_error() < 1e-3
    assert err < 0.01 * sag, (err, sag)
