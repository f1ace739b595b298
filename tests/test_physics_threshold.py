"""Shao & Lu (2000) threshold friction velocity against the paper's Table 2."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from saltstudy.config import load_case
from saltstudy.physics.threshold import threshold_for_soil, threshold_friction_velocity

# Table 2 of Dupont et al. (2013): case -> (mu1 [um], u*t [m/s]); typed in from dupont2013.toml.
TABLE2_UT = {1: (200, 0.26), 2: (200, 0.26), 3: (200, 0.26), 4: (200, 0.26), 5: (200, 0.26),
             6: (200, 0.26), 7: (90, 0.24), 8: (100, 0.24), 9: (300, 0.29), 10: (400, 0.33)}


@pytest.mark.parametrize("number", sorted(TABLE2_UT))
def test_table2_threshold_within_0p015(number):
    case = load_case(number)
    mu_um, ut_ref = TABLE2_UT[number]
    assert case.soil.mean_diameter == pytest.approx(mu_um * 1e-6)
    ut = threshold_for_soil(case.soil, case.air, case.threshold)
    assert abs(ut - ut_ref) <= 0.015
    # the CLI's positional call gives the same number
    ut_cli = threshold_friction_velocity(case.soil.mean_diameter, case.soil.rho_p, case.air.rho,
                                         case.air.g, case.threshold.A_N, case.threshold.gamma)
    assert ut_cli == ut


def test_hand_computed_value_200um():
    # 0.0123 * ((2650 - 1.2) * 9.81 * 2e-4 / 1.2 + 3e-4 / (1.2 * 2e-4)) = 0.068644 -> 0.26200 m/s
    ut = threshold_friction_velocity(200e-6, 2650.0, 1.2, 9.81)
    assert ut == pytest.approx(math.sqrt(0.0123 * (2648.8 * 9.81 * 2e-4 / 1.2 + 1.25)), rel=1e-12)
    assert ut == pytest.approx(0.26200, abs=5e-5)


def test_count_mean_diameter_reproduces_every_rounded_table_value():
    """Docstring claim of threshold.py: d = mu exp(-2.5 ln^2 sigma) matches Table 2 after rounding,
    while the mean diameter <d_p> misses the rounding for 300 and 400 um."""
    s2 = math.log(1.2) ** 2
    for mu_um, ut_ref in set(TABLE2_UT.values()):
        d = mu_um * 1e-6
        assert round(threshold_friction_velocity(d * math.exp(-2.5 * s2), 2650.0, 1.2, 9.81), 2) == ut_ref
    assert round(threshold_friction_velocity(300e-6, 2650.0, 1.2, 9.81), 2) == 0.30
    assert round(threshold_friction_velocity(400e-6, 2650.0, 1.2, 9.81), 2) == 0.34


def test_vectorised_matches_scalar():
    d = np.array([60e-6, 90e-6, 200e-6, 1e-3])
    arr = threshold_friction_velocity(d, 2650.0, 1.2, 9.81)
    assert isinstance(arr, np.ndarray) and arr.shape == d.shape
    for di, ai in zip(d, arr):
        assert threshold_friction_velocity(float(di), 2650.0, 1.2, 9.81) == ai
    assert isinstance(threshold_friction_velocity(2e-4, 2650.0, 1.2, 9.81), float)


def test_nonpositive_diameter_rejected():
    with pytest.raises(ValueError):
        threshold_friction_velocity(0.0, 2650.0, 1.2, 9.81)


@settings(deadline=None, max_examples=60)
@given(d=st.floats(5e-6, 5e-3), rho_p=st.floats(1000.0, 8000.0))
def test_minimum_at_cohesion_gravity_balance(d, rho_p):
    """d(u*t^2)/dd = 0 at d_min = sqrt(gamma / ((rho_p - rho) g)): u*t decreases below, rises above."""
    rho, g, gamma = 1.2, 9.81, 3e-4
    d_min = math.sqrt(gamma / ((rho_p - rho) * g))
    u_min = threshold_friction_velocity(d_min, rho_p, rho, g)
    u = threshold_friction_velocity(d, rho_p, rho, g)
    assert u >= u_min * (1 - 1e-12)
    u_further = threshold_friction_velocity(d * (1.1 if d > d_min else 1 / 1.1), rho_p, rho, g)
    assert u_further > u
