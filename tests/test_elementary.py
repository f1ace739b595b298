"""The inlined elementary functions of the parcel kernels (solver/numerics/elementary.py) against
correctly rounded references (40-digit decimal arithmetic), and the bed-crossing root finder."""
from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest

from saltstudy._jit import jit
from saltstudy.solver.numerics.elementary import (EXPM1_TAYLOR_MAX, expm1_small, expm1_taylor, log_small,
                                         pow_0687, pow_0687_table)
from saltstudy.solver.grains.motion import _crossing_time

getcontext().prec = 40
A = Decimal(0.687)  # the double the kernels' `** 0.687` raises to


@jit
def _pow_all(x, out):
    for i in range(x.size):
        out[i] = pow_0687(x[i])


@jit
def _expm1_all(x, out):
    for i in range(x.size):
        out[i] = expm1_small(x[i])


@jit
def _log_all(x, out):
    for i in range(x.size):
        out[i] = log_small(x[i])


@jit
def _branch_free_all(x, val, ok):
    """The branch-free parts the vectorized drag passes use: pow_0687_table, expm1_taylor."""
    for i in range(x.size):
        v, o = pow_0687_table(x[i])
        val[0, i] = v
        ok[0, i] = o
        val[1, i] = expm1_taylor(-x[i])
        ok[1, i] = abs(x[i]) <= EXPM1_TAYLOR_MAX


def _ulps(got, exact):
    """|got - exact| in units of the last place of the correctly rounded exact values."""
    ref = np.array([float(e) for e in exact])
    diff = np.array([abs(Decimal(g) - e) for g, e in zip(got, exact)], dtype=float)
    return diff / np.spacing(np.abs(ref))


def test_pow_0687_is_within_three_ulp_of_the_exact_power():
    rng = np.random.default_rng(7)
    x = np.concatenate([
        10.0 ** rng.uniform(-30, 30, 1500),  # the table's whole exponent range and beyond
        # both ends of mantissa bins (t = +-1/513) and binade edges
        np.ldexp(1.0 + np.arange(256) / 256.0, rng.integers(-20, 20, 256)),
        np.ldexp(1.0 + (np.arange(256) + 1) / 256.0 - 2.0 ** -52, rng.integers(-20, 20, 256)),
        2.0 ** np.arange(-128.0, 128.0), [1.0, 2.0 - 2.0 ** -52, 0.15, 37.0, 800.0],
    ])
    got = np.empty_like(x)
    _pow_all(x, got)
    exact = [(A * Decimal(v).ln()).exp() for v in x]
    assert _ulps(got, exact).max() <= 3.0


def test_pow_0687_falls_back_outside_its_table_and_keeps_ieee_special_values():
    x = np.array([5e-324, 1e-310, 2.0 ** -129, 2.0 ** 128, 1e300])  # beyond the table
    got = np.empty_like(x)
    _pow_all(x, got)
    assert _ulps(got, [(A * Decimal(v).ln()).exp() for v in x]).max() <= 3.0
    s = np.array([0.0, np.inf, np.nan, -1.0])
    got = np.empty_like(s)
    _pow_all(s, got)
    assert got[0] == 0.0 and got[1] == np.inf and np.isnan(got[2]) and np.isnan(got[3])


def test_log_small_is_within_two_ulp_of_the_exact_value_from_one_up():
    rng = np.random.default_rng(11)
    x = np.concatenate([
        np.exp(rng.uniform(0.0, 30.0, 1500)),  # the log law's z / z0 and far beyond
        1.0 + 10.0 ** rng.uniform(-15, -2, 300),  # near 1 (the series of log1p(x - 1))
        # both ends of mantissa bins and binade edges, the switch between the two forms
        np.ldexp(1.0 + np.arange(256) / 256.0, rng.integers(0, 40, 256)),
        np.ldexp(1.0 + (np.arange(256) + 1) / 256.0 - 2.0 ** -52, rng.integers(0, 40, 256)),
        [1.0001, 1.0 + 1.0 / 256.0, np.nextafter(1.0 + 1.0 / 256.0, 0.0), 2.0, 50.0, 1e300],
    ])
    got = np.empty_like(x)
    _log_all(x, got)
    exact = [Decimal(v).ln() for v in x]
    assert _ulps(got, exact).max() <= 2.0
    # below 1 and the IEEE special values: math.log's
    s = np.array([0.5, 1e-300, 0.0, np.inf, np.nan])
    got = np.empty_like(s)
    _log_all(s, got)
    assert got[0] == math.log(0.5) and got[1] == math.log(1e-300)
    assert got[2] == -np.inf and got[3] == np.inf and np.isnan(got[4])
    one = np.array([1.0])
    _log_all(one, got[:1])
    assert got[0] == 0.0


def test_branch_free_parts_agree_with_the_full_functions_where_they_say_they_do():
    """pow_0687_table and expm1_taylor (no branch, no call: the vectorized drag passes) are the
    full functions' values wherever they flag themselves valid, and flag the rest."""
    rng = np.random.default_rng(5)
    x = np.concatenate([10.0 ** rng.uniform(-45, 45, 2000), [0.0, -1.0, np.inf, np.nan, 0.2, 0.35,
                                                             np.nextafter(0.35, 1.0)]])
    val = np.empty((2, x.size))
    ok = np.zeros((2, x.size), dtype=np.bool_)
    _branch_free_all(x, val, ok)
    full = np.empty_like(x)
    _pow_all(x, full)
    assert np.array_equal(val[0, ok[0]], full[ok[0]])
    assert not ok[0, -7:-3].any() and ok[0, -3:].all()
    assert not ok[0, x > 2.0 ** 128].any() and not ok[0, (x > 0) & (x < 2.0 ** -128)].any()
    _expm1_all(-x, full)
    assert np.array_equal(val[1, ok[1]], full[ok[1]])
    assert ok[1].sum() == np.sum(np.abs(x) <= EXPM1_TAYLOR_MAX)


def _expm1_exact(v: float) -> Decimal:
    """e^v - 1 to 40 digits: the series below 1 in magnitude (exp(v) - 1 would cancel)."""
    x = Decimal(v)
    if abs(x) >= 1:
        return x.exp() - 1
    term, total, n = x, x, 1
    while abs(term) > abs(total) * Decimal("1e-45"):
        n += 1
        term = term * x / n
        total += term
    return total


def test_expm1_small_is_within_two_ulp_of_the_exact_value_on_both_sides_of_the_taylor_range():
    rng = np.random.default_rng(3)
    x = np.concatenate([
        -EXPM1_TAYLOR_MAX * 10.0 ** rng.uniform(-12, 0, 1500),
        EXPM1_TAYLOR_MAX * 10.0 ** rng.uniform(-12, 0, 300),
        [-EXPM1_TAYLOR_MAX, EXPM1_TAYLOR_MAX, np.nextafter(-EXPM1_TAYLOR_MAX, -1.0), -0.5, -3.0,
         -40.0, 1e-300, -1e-300],
    ])
    got = np.empty_like(x)
    _expm1_all(x, got)
    exact = [_expm1_exact(v) for v in x]
    assert _ulps(got, exact).max() <= 2.0
    z = np.array([0.0, -0.0])
    _expm1_all(z, got[:2])
    assert got[0] == 0.0 and got[1] == 0.0


def _crossing_reference(z0, wt, a, k, h, zc):
    """Bisection to the last bit on z(t) = z0 + w_t t - a expm1(-k t) / k (after the apex)."""
    lo, hi = 0.0, h
    if wt + a > 0.0 > wt:
        lo = min(math.log(a / -wt) / k, h)
    for _ in range(200):
        m = 0.5 * (lo + hi)
        if z0 + wt * m - a * math.expm1(-k * m) / k > zc:
            lo = m
        else:
            hi = m
    return 0.5 * (lo + hi)


def test_bed_crossing_time_is_the_root_to_round_off():
    """Parcels entering the impact layer within a step, falling or rising to their apex first,
    heavy and light (k from 3 to 300 s^-1), including a case whose iteration lands on an exact
    zero of z(t) - zc (it used to walk away from it by bisection)."""
    rng = np.random.default_rng(11)
    g, zc = 9.81, 5e-4
    cases = [(0.00054851995586316, -0.6286512116133505, 0.5529039025706378, 11.983040538887465,
              0.005)]
    while len(cases) < 3000:
        k = 10 ** rng.uniform(0.5, 2.5)
        h = 0.005 * rng.uniform(0.2, 2.0)
        wt = rng.normal(0.0, 0.3) - g / k
        a = rng.normal(-1.0, 1.0) - wt
        drop = wt * h - a * math.expm1(-k * h) / k  # z(h) - z(0)
        if drop < 0.0:
            cases.append((zc - drop * rng.uniform(0.0, 1.0), wt, a, k, h))
    eps = np.finfo(float).eps
    for z0, wt, a, k, h in cases:
        zh = z0 + wt * h - a * math.expm1(-k * h) / k
        t = _crossing_time(z0, wt, a, k, h, zc, zh)
        assert 0.0 <= t <= h
        ref = _crossing_reference(z0, wt, a, k, h, zc)
        # the root is known to the rounding of z(t)'s terms over the slope (a grazing crossing,
        # near an apex, is ill-conditioned); the iteration's own tolerance is 1e-14 h
        em = math.expm1(-k * ref)
        noise = 8 * eps * max(abs(z0), abs(wt * ref), abs(a * em / k)) / abs(wt + a * (1 + em))
        assert t == pytest.approx(ref, abs=2e-14 * h + noise)
