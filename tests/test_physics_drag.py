"""Drag law (jitted scalars) and the terminal fall speed."""
from __future__ import annotations


import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from saltstudy.physics.drag import (drag_correction, particle_response_time, particle_reynolds,
                                    terminal_velocity)

from physics_expectations import stokes_terminal_velocity, terminal_velocity_residual

RHO_P, RHO, NU, G = 2650.0, 1.2, 1.5e-5, 9.81


def _bisect_terminal(d, rho_p=RHO_P, rho=RHO, nu=NU, g=G):
    """Independent root of f(Re) w = g T_p by plain bisection on [0, Stokes speed]."""
    target = g * rho_p * d * d / (18 * rho * nu)
    lo, hi = 0.0, target
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid * (1 + 0.15 * (mid * d / nu) ** 0.687) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def test_jitted_scalar_laws_known_values():
    assert drag_correction(0.0) == 1.0
    assert drag_correction(1.0) == pytest.approx(1.15, rel=1e-14)
    assert drag_correction(100.0) == pytest.approx(1 + 0.15 * 100 ** 0.687, rel=1e-12)
    # T_p = 2650 * (2e-4)^2 / (18 * 1.2 * 1.5e-5) = 0.32716 s
    assert particle_response_time(2e-4, RHO_P, RHO, NU) == pytest.approx(0.327160493827, rel=1e-10)
    assert particle_reynolds(-3.0, 2e-4, NU) == pytest.approx(40.0, rel=1e-12)
    # numba and pure-Python agree
    assert drag_correction(37.0) == pytest.approx(drag_correction.py_func(37.0), rel=1e-12)


def test_stokes_limit_for_tiny_grains():
    d = np.array([1e-7, 1e-6, 3e-6])
    w = terminal_velocity(d, RHO_P, RHO, NU, G)
    ws = stokes_terminal_velocity(d, RHO_P, RHO, NU, G)
    re = ws * d / NU
    # w_s / w_t - 1 = 0.15 Re^0.687 to leading order
    np.testing.assert_allclose(ws / w - 1.0, 0.15 * re ** 0.687, rtol=1e-3)
    np.testing.assert_allclose(w, ws, rtol=5e-4)


@pytest.mark.parametrize("d", [10e-6, 90e-6, 200e-6, 400e-6, 1e-3])
def test_terminal_velocity_is_the_root_of_the_drag_law(d):
    w = terminal_velocity(d, RHO_P, RHO, NU, G)
    assert w == pytest.approx(_bisect_terminal(d), rel=1e-12)
    assert abs(terminal_velocity_residual(w, d, RHO_P, RHO, NU, G)) <= 1e-12 * w


def test_terminal_velocity_200um_quartz():
    w = terminal_velocity(200e-6, RHO_P, RHO, NU, G)
    assert w == pytest.approx(1.4823, abs=1e-3)          # Re_t ~ 20; Stokes would give 3.21 m/s
    assert stokes_terminal_velocity(200e-6, RHO_P, RHO, NU, G) == pytest.approx(3.2094, abs=1e-3)


@settings(deadline=None, max_examples=80)
@given(d=st.floats(1e-6, 2e-3), rho_p=st.floats(500.0, 8000.0))
def test_terminal_velocity_properties(d, rho_p):
    w = terminal_velocity(d, rho_p, RHO, NU, G)
    ws = stokes_terminal_velocity(d, rho_p, RHO, NU, G)
    assert 0 < w <= ws
    assert abs(terminal_velocity_residual(w, d, rho_p, RHO, NU, G)) <= 1e-11 * ws
    assert terminal_velocity(d * 1.01, rho_p, RHO, NU, G) > w


def test_vectorised_and_scalar_agree():
    d = np.array([50e-6, 200e-6, 700e-6])
    w = terminal_velocity(d, RHO_P, RHO, NU, G)
    assert w.shape == (3,)
    for di, wi in zip(d, w):
        assert terminal_velocity(float(di), RHO_P, RHO, NU, G) == pytest.approx(wi, rel=1e-13)
    with pytest.raises(ValueError):
        terminal_velocity(-1e-4, RHO_P, RHO, NU, G)
