"""Parcel-count overshoot, equilibrium time and energy ratio (analysis/series.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import series as se


def test_overshoot_series_gives_back_peak_plateau_and_equilibrium_time():
    t = np.arange(0, 90.0, 0.05)
    P, A, tau, t_pk = 6000.0, 1.5, 6.0, 3.0
    n = np.where(t < t_pk, P * (1 + A) * t / t_pk, P * (1 + A * np.exp(-(t - t_pk) / tau)))
    s = se.overshoot_stats(t, n, 30.0, 90.0)
    assert s["n_parcels_peak"] == pytest.approx(P * (1 + A), rel=1e-3)
    assert s["n_parcels_mean"] == pytest.approx(P, rel=2e-3)
    assert s["overshoot_ratio"] == pytest.approx(1 + A, rel=3e-3)
    expected = t_pk + tau * math.log(A / se.EQ_TOLERANCE)
    assert s["t_equilibrium"] == pytest.approx(expected, abs=0.1)


def test_monotonic_rise_equilibrium_time():
    t = np.arange(0, 60.0, 0.05)
    n = 100.0 * (1 - np.exp(-t / 4.0))
    s = se.overshoot_stats(t, n, 40.0, 60.0)
    assert s["overshoot_ratio"] == pytest.approx(1.0, abs=1e-3)
    assert s["t_equilibrium"] == pytest.approx(4.0 * math.log(10.0), abs=0.1)


def test_noisy_plateau_and_degenerate_series():
    rng = np.random.default_rng(0)
    t = np.arange(0, 30.0, 0.05)
    n = 500 + 20 * rng.standard_normal(t.size)
    s = se.overshoot_stats(t, n, 10.0, 30.0)
    assert s["t_equilibrium"] == pytest.approx(0.0, abs=0.5)   # in equilibrium from the start
    z = se.overshoot_stats(t, 0 * t, 10.0, 30.0)
    assert z["n_parcels_peak"] == 0.0 and math.isnan(z["overshoot_ratio"])
    e = se.overshoot_stats(np.zeros(0), np.zeros(0), 0.0, 1.0)
    assert all(math.isnan(v) for v in e.values())


def test_increment_ratio_over_the_window():
    t = np.arange(0, 10.0, 0.1)
    E_imp = np.where(t < 5, 3.0 * t, 15.0 + 10.0 * (t - 5))
    E_spl = np.where(t < 5, 3.0 * t, 15.0 + 6.0 * (t - 5))     # ratio 1 early, 0.6 later
    assert se.increment_ratio(t, E_spl, E_imp, 5.0, 9.9) == pytest.approx(0.6)
    assert se.increment_ratio(t, E_spl, E_imp, 5.0, 5.0) == pytest.approx(E_spl[-1] / E_imp[-1])
    assert math.isnan(se.increment_ratio(t, 0 * t, 0 * t, 5.0, 9.0))


def test_block_stress_u_star_of_a_two_level_series():
    """A stress that is 0.25 for half the window and 0.36 for the other: u* of the mean stress is
    sqrt(0.305); three 10-s blocks give the block scatter carried to u*."""
    import math

    import numpy as np

    from saltstudy.analysis.series import block_mean_stress_u_star

    t = np.arange(0.0, 42.0, 0.01)
    u = np.where(t < 27.0, 0.5, 0.6)
    mean_u, se, n = block_mean_stress_u_star(t, u, 12.0, 42.0)
    assert n == 3
    tau = np.where(t < 27.0, 0.25, 0.36)[(t >= 12.0) & (t <= 42.0)]
    assert mean_u == math.sqrt(tau.mean())
    blocks = [0.25, (0.25 + 0.36) / 2, 0.36]
    assert se == __import__("pytest").approx(np.std(blocks, ddof=1) / math.sqrt(3) / (2 * mean_u),
                                             rel=1e-3)
    assert math.isnan(block_mean_stress_u_star(t, u, 12.0, 25.0)[1])
