"""Splash laws (eqs. 6-9): the draws the kernels make against their specification, expectations."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from saltstudy._jit import jit
from saltstudy.config import Soil, SoilMode, Splash, load_case
from saltstudy.physics.soil import soil_arrays
from saltstudy.physics.splash import (draw_impact, ejecta_number, ejection_number_mean,
                                      ejection_speed, launch_angle, rebound_probability,
                                      rebound_speed, splash_constants, splash_impacts)

from physics_expectations import (mass_weighted_moment, mean_ejecta_number, mean_ejecta_speed,
                                  mean_rebound_fraction, mean_rebound_speed,
                                  mean_splash_energy_ratio, mean_splash_energy_terms,
                                  rebound_speed_ratio_moments, std_rebound_speed,
                                  truncated_normal_moments, vertical_angle_moments)

SPLASH = Splash()
SOIL = Soil()
G = 9.81
N = 100_000
SP = splash_constants(SPLASH, SOIL, G)


def _within(sample, mean, std, kurtosis=3.0, k=4.0):
    """Sample mean and std agree with (mean, std) within k standard errors."""
    n = sample.size
    se_mean = std / math.sqrt(n)
    se_std = std * math.sqrt((kurtosis - 1.0) / (4.0 * n))
    return abs(sample.mean() - mean) < k * se_mean and abs(sample.std() - std) < k * se_std


@jit
def _draws(rng, kind, a, b, c, n):
    """n draws of one law: 0 rebound_speed(a, b, c), 1 launch_angle(a, b), 2 ejecta_number(a),
    3 ejection_speed(a, b)."""
    out = np.empty(n)
    for i in range(n):
        if kind == 0:
            out[i] = rebound_speed(rng, a, b, c)
        elif kind == 1:
            out[i] = launch_angle(rng, a, b)
        elif kind == 2:
            out[i] = ejecta_number(rng, a)
        else:
            out[i] = ejection_speed(rng, a, b)
    return out


@jit
def _impacts(rng, v, sp, n):
    """n impacts at speed v (draw_impact): rebounded, v_reb, alpha_v, alpha_h, N_ej each."""
    out = np.empty((n, 5))
    for i in range(n):
        reb, vr, av, ah, nej = draw_impact(rng, v, v, sp)
        out[i, 0] = 1.0 if reb else 0.0
        out[i, 1] = vr
        out[i, 2] = av
        out[i, 3] = ah
        out[i, 4] = nej
    return out


# ---------------------------------------------------------------- the scalar laws
def test_rebound_probability():
    assert rebound_probability(0.0, 0.95, 2.0) == 0.0
    assert rebound_probability(1.0, 0.95, 2.0) == pytest.approx(0.95 * (1 - math.exp(-2.0)), rel=1e-14)
    assert rebound_probability(50.0, 0.95, 2.0) == pytest.approx(0.95, rel=1e-12)
    assert rebound_probability(0.7, 0.95, 2.0) == pytest.approx(rebound_probability.py_func(0.7, 0.95, 2.0))


def test_ejection_number():
    # 0.03 * 3 / sqrt(9.81 * 2e-4) = 0.09 / 0.0442945 = 2.03186
    assert ejection_number_mean(3.0, 0.03, G, 200e-6) == pytest.approx(2.03186, abs=1e-5)
    assert ejection_number_mean(3.0, 0.03, G, 200e-6) == mean_ejecta_number(3.0, SPLASH, G, 200e-6)


# ---------------------------------------------------------------- truncated normal
def test_truncated_normal_moments_known_values():
    m, s = truncated_normal_moments(0.6, 0.25, 0.0)
    phi, Phi = math.exp(-0.5 * 2.4 ** 2) / math.sqrt(2 * math.pi), 0.5 * math.erfc(-2.4 / math.sqrt(2))
    assert m == pytest.approx(0.6 + 0.25 * phi / Phi, rel=1e-14)
    assert m == pytest.approx(0.605645, abs=1e-6)
    assert truncated_normal_moments(0.0, 1.0) == (0.0, 1.0)
    # half-normal: mean sqrt(2/pi), std sqrt(1 - 2/pi)
    m, s = truncated_normal_moments(0.0, 1.0, 0.0)
    assert (m, s) == pytest.approx((math.sqrt(2 / math.pi), math.sqrt(1 - 2 / math.pi)), rel=1e-12)


@settings(deadline=None, max_examples=25)
@given(mean=st.floats(0.0, 2.0), std=st.floats(0.2, 2.0))
def test_redrawn_rebound_ratio_matches_the_truncated_moments(mean, std):
    """rebound_speed redraws the negative draws: its ratio to v_imp is N(mean, std) truncated to
    >= 0, whose moments truncated_normal_moments gives."""
    x = _draws(np.random.default_rng(11), 0, 2.0, mean, std, 20_000) / 2.0
    assert np.all(x >= 0)
    m, s = truncated_normal_moments(mean, std, 0.0)
    assert abs(x.mean() - m) < 4.5 * s / math.sqrt(x.size)


# ---------------------------------------------------------------- rebound
@pytest.mark.parametrize("v_imp", [0.5, 2.0, 5.0])
def test_rebound_draws_match_specification(v_imp):
    out = _impacts(np.random.Generator(np.random.PCG64(2013)), v_imp, SP, N)
    reb = out[:, 0] == 1.0
    p = mean_rebound_fraction(v_imp, SPLASH)
    assert p == pytest.approx(0.95 * (1 - math.exp(-2 * v_imp)))
    assert abs(reb.mean() - p) < 4 * math.sqrt(p * (1 - p) / N)
    speed, av, ah = out[reb, 1], np.degrees(out[reb, 2]), np.degrees(out[reb, 3])
    assert np.all(speed > 0)
    assert _within(speed, mean_rebound_speed(v_imp, SPLASH), std_rebound_speed(v_imp, SPLASH))
    assert np.all((av > 0) & (av < 180))
    assert _within(av, *vertical_angle_moments(30.0, 15.0))
    assert _within(ah, 0.0, 10.0)


def test_rebound_speed_mean_is_the_truncated_one_not_0p6():
    """The test above can fail: the untruncated mean 0.6 v_imp is rejected by the same sample."""
    speed = _draws(np.random.default_rng(2013), 0, 2.0, 0.6, 0.25, N)
    m, s = rebound_speed_ratio_moments(SPLASH)
    assert abs(speed.mean() - 0.6 * 2.0) > 4 * 2.0 * s / math.sqrt(N)
    assert abs(speed.mean() - m * 2.0) < 4 * 2.0 * s / math.sqrt(N)
    assert m == pytest.approx(0.60564, abs=1e-5)


def test_vertical_rebound_angles_redrawn_not_clipped():
    av = np.degrees(_draws(np.random.default_rng(9), 1, math.radians(30.0), math.radians(15.0),
                           0.0, N))
    # near 0 the density of a redrawn (truncated) normal is that of N(30, 15) / Phi(2), no atom at 0
    assert np.min(av) > 0 and np.mean(av < 1.0) < 0.01


# ---------------------------------------------------------------- ejecta number
@pytest.mark.parametrize("v_imp", [0.3, 1.0, 3.0, 7.5])
def test_ejecta_number_by_stochastic_rounding(v_imp):
    k = _impacts(np.random.default_rng(42), v_imp, SP, N)[:, 4]
    mean = mean_ejecta_number(v_imp, SPLASH, G, 200e-6)
    f = mean - math.floor(mean)
    assert set(np.unique(k)) <= {math.floor(mean), math.floor(mean) + 1}
    assert abs(k.mean() - mean) < 4 * math.sqrt(f * (1 - f) / N) + 1e-12
    assert k.var() == pytest.approx(f * (1 - f), abs=4 * math.sqrt(f * (1 - f) / N) + 1e-12)


def test_ejecta_number_integer_mean_is_deterministic():
    d_mean = 200e-6
    v = 2.0 * math.sqrt(G * d_mean) / SPLASH.a_ej        # N = 2 exactly
    k = _draws(np.random.default_rng(0), 2, ejection_number_mean(v, SPLASH.a_ej, G, d_mean), 0.0,
               0.0, 1000)
    assert np.all(k == 2)


# ---------------------------------------------------------------- ejection
@pytest.mark.parametrize("v_imp", [1.0, 4.0])
def test_ejection_draws_match_specification(v_imp):
    impactors = np.full(N // 20, v_imp)
    launch, parent = splash_impacts(np.random.default_rng(77), impactors, 0.0 * impactors,
                                    0.0 * impactors, np.full(N // 20, 1.0), SP,
                                    *soil_arrays(SOIL))
    ejecta = launch[:, 3] != 1.0          # rebounds keep the impactor's (here unphysical) diameter
    u, v, w = launch[ejecta, 0], launch[ejecta, 1], launch[ejecta, 2]
    speed = np.sqrt(u * u + v * v + w * w)
    m = mean_ejecta_speed(v_imp, SPLASH)
    assert m == pytest.approx(0.08 * v_imp)
    assert _within(speed, m, m, kurtosis=9.0)                  # exponential: std = mean
    # the impactors move along x: the horizontal angle is small, and an elevation above 90 deg
    # points upwind (u < 0)
    c = np.sign(u) * np.hypot(u, v)
    assert _within(np.degrees(np.arctan2(w, c)), *vertical_angle_moments(60.0, 15.0))
    assert vertical_angle_moments(60.0, 15.0)[0] == pytest.approx(60.0, abs=0.003)
    assert _within(np.degrees(np.arctan(v / u)), 0.0, 10.0)
    assert np.array_equal(parent, np.sort(parent))             # impact after impact


# ---------------------------------------------------------------- energy
def test_energy_ratio_matches_monte_carlo():
    """Splash 1e5 impacts (rebound + ejecta with diameters from the soil) and compare."""
    soil = Soil(modes=(SoilMode(mu=200e-6, sigma=1.2),))
    v, d_imp = 3.0, 180e-6
    ui = np.full(N, v)
    launch, parent = splash_impacts(np.random.default_rng(99), ui, 0.0 * ui, 0.0 * ui,
                                    np.full(N, d_imp), splash_constants(SPLASH, soil, G),
                                    *soil_arrays(soil))
    e_out = launch[:, 3] ** 3 * np.sum(launch[:, :3] ** 2, axis=1)    # rho_p pi/12 cancels
    per_impact = np.bincount(parent, weights=e_out, minlength=N) / (d_imp ** 3 * v ** 2)
    ratio = mean_splash_energy_ratio(v, d_imp, soil, SPLASH, G)
    assert abs(per_impact.mean() - ratio) < 4 * per_impact.std() / math.sqrt(N)
    reb_term, ej_term = mean_splash_energy_terms(v, d_imp, soil, SPLASH, G)
    assert ratio == pytest.approx(reb_term + ej_term)
    m, s = rebound_speed_ratio_moments(SPLASH)
    assert reb_term == pytest.approx(0.95 * (1 - math.exp(-6)) * (m * m + s * s))
    assert ej_term == pytest.approx(mean_ejecta_number(v, SPLASH, G, 200e-6)
                                    * mass_weighted_moment(soil, 3) / d_imp ** 3 * 2 * 0.08 ** 2)


@pytest.mark.parametrize("number", [1, 7, 8, 9, 10])
def test_paper_soils_do_not_create_energy(number):
    """Paper section 2.3: on average rebound + ejecta energy <= impact energy (impactor at mu1)."""
    case = load_case(number)
    v = np.linspace(0.05, 20.0, 200)
    r = mean_splash_energy_ratio(v, case.soil.modes[0].mu, case.soil, case.splash, case.air.g)
    assert np.all(r < 1.0)
    assert np.all(np.diff(r) > 0)


def test_energy_ratio_ejection_only_on_rebound_is_smaller():
    soil = Soil()
    a = mean_splash_energy_ratio(1.0, 200e-6, soil, SPLASH, G)
    b = mean_splash_energy_ratio(1.0, 200e-6, soil, SPLASH, G, ejecta_require_rebound=True)
    assert b < a


@settings(deadline=None, max_examples=50)
@given(v=st.floats(0.01, 30.0), d_imp=st.floats(100e-6, 600e-6))
def test_energy_terms_scale(v, d_imp):
    """Rebound term is P_reb(v) times a constant; ejecta term is linear in v and in d_imp^-3."""
    soil = Soil()
    reb, ej = mean_splash_energy_terms(v, d_imp, soil, SPLASH, G)
    reb2, ej2 = mean_splash_energy_terms(2 * v, d_imp / 2, soil, SPLASH, G)
    assert ej2 == pytest.approx(16.0 * ej, rel=1e-12)
    assert reb / mean_rebound_fraction(v, SPLASH) == pytest.approx(reb2 / mean_rebound_fraction(2 * v, SPLASH))
